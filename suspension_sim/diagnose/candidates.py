"""The library of candidate missing effects, built from the registries.

Every registered effect that declares ``free_parameters`` (:mod:`suspension_sim.free_parameters`) is a
candidate, and so is every free parameter the ideal actuator declares (``actuator_lag``,
``actuator_delay``) when a force input is measured, and ``parameter:<name>`` for every nominal parameter
that the model states as known.  Nothing here names an effect: a new effect file with a declaration is a
candidate at once.

On a car with more than one axle, each effect is also tried on one axle only (``bump_stop@front``), and on
the full car on one corner only (``bump_stop@fl``): an effect on one axle or corner is not fitted as a
weaker effect on all of them.

A candidate adds its parameters (starting values from the declared multiples of the data scales: the
travel, travel-rate and suspension-force levels of the nominal simulation), and writes its fitted values as
a ``vehicle.effects`` entry, ideal-actuator parameters or a changed nominal parameter.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..free_parameters import scale_of
from ..registry import ACTUATORS
from .engine import effect_candidates
from .model import EffectEntry, FreeParam, ModelSpec, nominal_bounds, positive


@dataclass
class Scales:
    """Data-derived magnitudes from the nominal model's simulation on the training data."""

    s: float  # RMS travel (m)
    s_max: float  # max |travel|
    v: float  # RMS travel rate (m/s)
    F: float  # RMS linear suspension force (N)
    k: float  # spring stiffness in use (N/m)
    c: float  # damping in use (N s/m)
    has_force: bool
    has_tire: bool = True
    s_comp: float = 0.0  # largest compression (max of −travel; 0: s_max)
    s_ext: float = 0.0  # largest extension (max of travel; 0: s_max)

    def as_dict(self) -> dict:
        return {"s": self.s, "s_max": self.s_max, "v": self.v, "F": self.F, "k": self.k, "c": self.c,
                "s_comp": self.s_comp or self.s_max, "s_ext": self.s_ext or self.s_max}


class Candidate:
    name = ""
    signature = ""
    parent: str | None = None  # a placement tried only when this candidate lowered the training BIC (full car)

    def applies(self, spec: ModelSpec, sc: Scales) -> tuple[bool, str]:
        return True, ""

    def augment(self, spec: ModelSpec, sc: Scales) -> tuple[ModelSpec, list]:
        """(the model with this candidate added, starting vectors of all free parameters)."""
        raise NotImplementedError

    def describe(self, P: dict) -> dict:
        raise NotImplementedError

    size_names: list = []
    contains_free: list = []  # free linear parameters the effect contains (fitted beside them as a signed difference)


def _free_params(prefix, decl: dict, sc: Scales):
    """FreeParams and the candidate's own start list from declarations."""
    d = sc.as_dict()
    fps, starts = [], []
    nstart = max([len(fp.starts) for fp in decl.values()] + [1])
    for pn, fp in decl.items():
        u = scale_of(fp.scale, d)
        lo = -np.inf if fp.lo is None else fp.lo * u
        hi = np.inf if fp.hi is None else fp.hi * u
        fps.append(FreeParam(f"{prefix}{pn}" if fp.target is None else fp.target, fp.init * u, lo, hi, u,
                             size=fp.size, unseen=None if fp.unseen is None else fp.unseen * u))
    for k in range(nstart):
        starts.append([(fp.starts[k] if k < len(fp.starts) else fp.init) * scale_of(fp.scale, d)
                       for fp in decl.values()])
    return fps, starts


class EffectCandidate(Candidate):
    def __init__(self, etype: str, ecls, corners="all", placement: str | None = None, parent: str | None = None):
        self.etype, self.ecls, self.corners = etype, ecls, corners
        self.name = etype if placement is None else f"{etype}@{placement}"
        self.signature = getattr(ecls, "signature", "")
        # the smallest placement that holds this one (a corner's axle, an axle's "all"): on the full car a
        # placement is tried only when its parent lowered the training BIC in the same round (Selector)
        self.parent = parent

    def applies(self, spec, sc):
        if any(e.type == self.etype for e in spec.effects):
            return False, "already in the model"
        if self.ecls.target == "tire" and (spec.kind in ("sdof", "damper") or not sc.has_tire):
            return False, "the model has no tire"
        return True, ""

    def contained(self, spec: ModelSpec) -> dict:
        """The free linear parameters of ``spec`` that this effect contains on its corners (the effect's
        ``contains`` declaration, :mod:`suspension_sim.free_parameters`): {vehicle parameter: (the effect's two
        parameters that equal it when the effect is that element)}."""
        from .engine import linear_params

        free = {f.name for f in spec.free}
        out = {}
        for qty, pair in (getattr(self.ecls, "contains", None) or {}).items():
            for vp in linear_params(spec.kind, qty, self.corners):
                if vp in free:
                    out[vp] = tuple(pair)
        return out

    def augment(self, spec, sc):
        sp = spec.copy()
        label = self.name
        sp.effects.append(EffectEntry(label, self.etype, self.corners, dict(getattr(self.ecls, "fit_settings", {}) or {})))
        fps, own = _free_params(f"{label}.", self.ecls.free_parameters, sc)
        # beside a free linear element of its corners that it contains, the effect's two parameters are fitted as
        # one signed difference (free_parameters.py, ``contains``): the linear parameter carries what they share
        held = self.contained(spec)
        self.contains_free = list(held)
        for pos, neg in {pair for pair in held.values()}:
            names = [f.name for f in fps]
            i, j = names.index(f"{label}.{pos}"), names.index(f"{label}.{neg}")
            fi, fj = fps[i], fps[j]
            signed = FreeParam(f"{label}.{pos}_minus_{neg}", fi.init - fj.init, -np.inf, np.inf, fi.scale,
                               size=fi.size or fj.size, split=(fi.name, fj.name))
            sp.P[fi.name], sp.P[fj.name] = max(signed.init, 0.0), max(-signed.init, 0.0)
            own = [[o[k] for k in range(len(o)) if k not in (i, j)] + [o[i] - o[j]] for o in own]
            fps = [f for k, f in enumerate(fps) if k not in (i, j)] + [signed]
        for f in fps:
            sp.P[f.name] = f.init
        self.size_names = [f.name for f in fps if f.size]
        sp.free = sp.free + fps
        base = [f.init for f in spec.free]
        return sp, [base + o for o in own]

    def describe(self, P):
        params = {pn: P[f"{self.name}.{pn}"] for pn in self.ecls.free_parameters}
        params.update(getattr(self.ecls, "fit_settings", {}) or {})
        e = {"type": self.etype, "params": params}
        if self.corners != "all":
            e["corners"] = list(self.corners)
        return {"effect": e}


class ActuatorCandidate(Candidate):
    def __init__(self, pname: str, fp, acls):
        self.pname, self.fp = pname, fp
        self.name = fp.candidate or f"actuator.{pname}"
        self.signature = getattr(acls, "signatures", {}).get(self.name, "")

    def applies(self, spec, sc):
        if not sc.has_force:
            return False, "no force input measured"
        key = self.fp.target or f"actuator.{self.pname}"
        if any(f.name == key for f in spec.free) or (key == "actuator.time_constant" and spec.lag):
            return False, "already in the model"
        return True, ""

    def augment(self, spec, sc):
        sp = spec.copy()
        fps, own = _free_params("actuator.", {self.pname: self.fp}, sc)
        if fps[0].name == "actuator.time_constant":
            sp.lag = True
        sp.P[fps[0].name] = fps[0].init
        self.size_names = [fps[0].name]
        sp.free = sp.free + fps
        base = [f.init for f in spec.free]
        return sp, [base + o for o in own]

    def describe(self, P):
        key = self.fp.target or f"actuator.{self.pname}"
        return {"actuator": {self.pname: P[key]}}


class ParameterCandidate(Candidate):
    """A nominal parameter that the model states as known is wrong: it is freed and refitted within the
    model's bounds factor of its stated value."""

    signature = ("a mis-set mass or stiffness shifts a resonance, a mis-set damping changes its height; a "
                 "heavier car sags (positions zeroed at the nominal ride height)")

    def __init__(self, pname: str):
        self.pname = pname
        self.name = f"parameter:{pname}"

    def applies(self, spec, sc):
        if self.pname not in spec.fixed_nominal:
            return False, "already calibrated (free)"
        return True, ""

    def augment(self, spec, sc):
        sp = spec.copy()
        v = float(sp.P[self.pname])
        lo, hi = nominal_bounds(self.pname, v, spec.bounds_factor)
        if positive(self.pname):
            lo = max(lo, 1e-9)
        scale = abs(v) if v != 0 else zero_nominal_scale(self.pname, sc, lo, hi)
        sp.free = sp.free + [FreeParam(self.pname, v, lo, hi, scale)]
        sp.fixed_nominal = [n for n in sp.fixed_nominal if n != self.pname]
        self.size_names = [(self.pname, v)]  # named only when it differs from the stated value beyond its error
        return sp, [[f.init for f in sp.free]]

    def describe(self, P):
        return {"param": {self.pname: P[self.pname]}}


def zero_nominal_scale(pname: str, sc: Scales, lo: float = 0.0, hi: float = np.inf) -> float:
    """The scale of a parameter whose stated value is 0 (a tire damping, the spring of a pure integrator):
    from the data by its unit (a stiffness: max(k, F/s); a damping: max(c, F/v)), else from its declared
    bounds.  A scale of the stated value (0, floored at 1e-9) made the finite-difference step 1e-13 in SI
    units: the parameter could never leave 0, and was judged indistinguishable from it."""
    n = pname.lower()
    if "stiffness" in n or n.startswith("arb"):
        u = max(sc.k, sc.F / max(sc.s, 1e-12))
    elif "damping" in n:
        u = max(sc.c, sc.F / max(sc.v, 1e-12))
    elif np.isfinite(lo) and np.isfinite(hi) and hi > lo:
        u = 0.5 * (abs(lo) + abs(hi))
    elif np.isfinite(hi) and hi != 0:
        u = abs(hi)
    else:
        u = 1.0
    return float(u) if np.isfinite(u) and u > 0 else 1.0


def _axles(kind: str) -> dict[str, list[str]]:
    """Corner names per axle (front/rear) of a multi-axle car, from the vehicle's corners."""
    if kind in ("damper", "sdof"):
        return {}
    from .engine import corner_layout

    cs = corner_layout(kind)
    if len(cs) < 2:
        return {}
    xs = sorted({c.x for c in cs})
    if len(xs) < 2:
        return {}
    return {"front": [c.name for c in cs if c.x == xs[-1]], "rear": [c.name for c in cs if c.x == xs[0]]}


def _placements(kind: str) -> dict[str, list[str]]:
    """Where an effect may sit besides everywhere: each axle of a multi-axle car, and each corner where an
    axle has more than one (the full car: ``fl``, ``fr``, ``rl``, ``rr``)."""
    return {k: c for k, (c, _parent) in _placement_tree(kind).items()}


def _placement_tree(kind: str) -> dict[str, tuple[list[str], str | None]]:
    """The placements of :func:`_placements` with their parents: an axle's is everywhere (None), a corner's its
    axle."""
    axles = _axles(kind)
    out = {ax: (cs, None) for ax, cs in axles.items()}
    if any(len(c) > 1 for c in axles.values()):
        for ax, corners in axles.items():
            for c in corners:
                out[c] = ([c], ax)
    return out


def staged(kind: str) -> bool:
    """Whether the placements of this model kind are searched nested (a corner only when its axle, an axle
    only when everywhere lowered the training BIC): the full car, whose 7 placements per effect (everywhere,
    2 axles, 4 corners) made a round 9 × 7 effect fits; a half car's 3 are all tried."""
    return any(parent is not None for _c, parent in _placement_tree(kind).values())


def library(spec: ModelSpec, placements: bool = True) -> list[Candidate]:
    """Every candidate for the model: registered effects with declarations (and their axle placements),
    the ideal actuator's declared parameters, and every stated-known writable nominal parameter."""
    from .engine import writable_params

    out: list[Candidate] = []
    tree = _placement_tree(spec.kind) if placements else {}
    nested = staged(spec.kind)
    for etype, ecls in effect_candidates().items():
        out.append(EffectCandidate(etype, ecls))
        for ax, (corners, parent) in tree.items():
            par = (etype if parent is None else f"{etype}@{parent}") if nested else None
            out.append(EffectCandidate(etype, ecls, corners, ax, par))
    if spec.kind != "damper":
        acls = ACTUATORS.get("ideal")
        for pn, fp in (getattr(acls, "free_parameters", None) or {}).items():
            out.append(ActuatorCandidate(pn, fp, acls))
    writable = writable_params(spec.kind)
    for pn in spec.fixed_nominal:
        if pn in writable:
            out.append(ParameterCandidate(pn))
    return out


def names(kind: str = "quarter_car") -> list[str]:
    """Effect and actuator candidate names (for ``--candidates``)."""
    out = list(effect_candidates())
    acls = ACTUATORS.get("ideal")
    out += [fp.candidate for fp in (getattr(acls, "free_parameters", None) or {}).values() if fp.candidate]
    return out
