"""The model being diagnosed: nominal parameters (fixed or free), known effects, and the mapping between the
``vehicle`` block of a scenario and the parameter vector of :mod:`.fastsim`.

MODEL.yaml is the ``vehicle`` block of a scenario (``model``, ``params``, ``effects``), or a whole scenario
with one.  A parameter is *free* (calibrated) when it is absent, written ``free`` (or ``?``), or written as
``{value: 2.1, free: true}``; a plain number is known and fixed.  Two optional keys describe the measured
force input (they are not vehicle parameters): ``inputs: {force_gain: 1.0, force_offset: free}`` (the
actuator force is ``gain·u + offset``; by default the gain is 1 and the offset is free when a force input is
measured).  ``model: damper`` describes a force element alone (params ``spring_stiffness``, ``damping``).
``model: half_car`` takes the parameters of :mod:`suspension_sim.vehicles.half_car` (per corner with
``_front``/``_rear``; ``cg_height`` is kept but does not enter the diagnosis).  For a half car the geometry
``a``, ``b`` and ``pitch_inertia`` are free when absent like everything else: give them when known.  Added
effects act at both corners with shared parameters (one candidate = one effect on the whole axle pair).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ScenarioError
from . import fastsim as fs

NOMINAL = {
    "quarter_car": {"sprung_mass": fs.MS, "unsprung_mass": fs.MU, "spring_stiffness": fs.K, "damping": fs.C,
                    "tire_stiffness": fs.KT, "tire_damping": fs.CT},
    "sdof": {"sprung_mass": fs.MS, "spring_stiffness": fs.K, "damping": fs.C},
    "damper": {"spring_stiffness": fs.K, "damping": fs.C},
    # half car: nominal parameters per corner (as in suspension_sim/vehicles/half_car.py); effects are shared
    "half_car": {"sprung_mass": fs.MS, "pitch_inertia": fs.IYY, "a": fs.HA, "b": fs.HB,
                 "unsprung_mass_front": fs.MU, "unsprung_mass_rear": fs.MU_R,
                 "spring_stiffness_front": fs.K, "spring_stiffness_rear": fs.K_R,
                 "damping_front": fs.C, "damping_rear": fs.C_R,
                 "tire_stiffness_front": fs.KT, "tire_stiffness_rear": fs.KT_R,
                 "tire_damping_front": fs.CT, "tire_damping_rear": fs.CT_R},
}
DEFAULTS = {
    "quarter_car": {"sprung_mass": 290.0, "unsprung_mass": 59.0, "spring_stiffness": 16812.0, "damping": 1000.0,
                    "tire_stiffness": 190000.0, "tire_damping": 0.0},
    "sdof": {"sprung_mass": 250.0, "spring_stiffness": 5000.0, "damping": 250.0},
    "damper": {"spring_stiffness": 0.0, "damping": 1000.0},
    "half_car": {"sprung_mass": 500.0, "pitch_inertia": 1125.0, "a": 1.5, "b": 1.5, "unsprung_mass_front": 45.0,
                 "unsprung_mass_rear": 45.0, "spring_stiffness_front": 17000.0, "spring_stiffness_rear": 17000.0,
                 "damping_front": 1250.0, "damping_rear": 1250.0, "tire_stiffness_front": 100000.0,
                 "tire_stiffness_rear": 100000.0, "tire_damping_front": 0.0, "tire_damping_rear": 0.0},
}
POSITIVE = {"sprung_mass", "unsprung_mass", "tire_stiffness", "pitch_inertia", "a", "b", "unsprung_mass_front",
            "unsprung_mass_rear", "tire_stiffness_front", "tire_stiffness_rear"}
# vehicle parameters that do not enter the diagnosed dynamics (kept in the fitted model as given)
IGNORED = {"half_car": {"cg_height"}}
# effects of the vehicle block we can represent in the fast simulator: type -> {param: slot}
EFFECT_SLOTS = {
    "coulomb_friction": {"force": fs.CF, "v_eps": fs.VEPS},
    "quadratic_damping": {"c_v": fs.CV},
    "asymmetric_damping": {"c_comp": fs.CCOMP, "c_reb": fs.CREB},
    "bump_stop": {"gap": fs.GAP, "stiffness": fs.KSTOP},
    "cubic_stiffness": {"k3": fs.K3},
    "tire_liftoff": {},
    "hysteresis": {"force": fs.BWF, "x_y": fs.BWX},
    "backlash": {"stiffness": fs.BLK, "play": fs.BLB},
}
EFFECT_DEFAULTS = {"coulomb_friction": {"v_eps": 0.01}, "hysteresis": {"x_y": 0.01}}


@dataclass
class FreeParam:
    """A fitted parameter: ``name`` (as reported), how its value ``x`` sets slots of the parameter vector."""

    name: str
    slot: int
    init: float
    lo: float = -np.inf
    hi: float = np.inf
    scale: float = 1.0
    signed_pair: int | None = None  # x < 0 goes to this slot as −x, x > 0 to ``slot`` (asymmetric damping)

    def apply(self, P: np.ndarray, x: float) -> None:
        if self.signed_pair is None:
            P[self.slot] = x
        else:
            P[self.slot] = max(x, 0.0)
            P[self.signed_pair] = max(-x, 0.0)


@dataclass
class ModelSpec:
    kind: str
    P: np.ndarray  # base parameter vector (fixed values and starting values)
    free: list[FreeParam]
    effects: list[str] = field(default_factory=list)  # effect types present (known or added)
    fixed_nominal: list[str] = field(default_factory=list)  # nominal params the model says are known
    source: str = ""
    raw: dict = field(default_factory=dict)

    def copy(self) -> "ModelSpec":
        return ModelSpec(self.kind, self.P.copy(), [copy.copy(f) for f in self.free], list(self.effects),
                         list(self.fixed_nominal), self.source, copy.deepcopy(self.raw))

    def vector(self, x) -> np.ndarray:
        P = self.P.copy()
        for f, v in zip(self.free, x):
            f.apply(P, float(v))
        return P

    @property
    def x0(self) -> np.ndarray:
        return np.array([f.init for f in self.free], float)

    def names(self) -> list[str]:
        return [f.name for f in self.free]


def _is_free(v) -> tuple[bool, float | None]:
    if isinstance(v, str) and v.strip().lower() in ("free", "?"):
        return True, None
    if isinstance(v, dict):
        val = v.get("value")
        return bool(v.get("free", False)), (None if val is None else float(val))
    try:
        return False, float(v)
    except (TypeError, ValueError):
        raise ScenarioError(f"parameter value {v!r} is not a number, 'free' or {{value, free}}") from None


def load_model(path_or_dict, source: str | None = None) -> ModelSpec:
    """Read MODEL.yaml (a vehicle block or a scenario with one) into a :class:`ModelSpec`."""
    if isinstance(path_or_dict, (str, Path)):
        source = str(path_or_dict)
        from ..safeyaml import load_file  # size/alias/depth limits, UTF-8, duplicate keys refused

        raw = load_file(path_or_dict, "model file")
    else:
        raw = copy.deepcopy(path_or_dict)
    if not isinstance(raw, dict):
        raise ScenarioError("the model must be a YAML mapping (a vehicle block)", source=source)
    if "vehicle" in raw and isinstance(raw["vehicle"], dict):
        inputs = raw.get("inputs", raw["vehicle"].get("inputs", {}))
        raw = dict(raw["vehicle"])
        raw["inputs"] = inputs
    raw = dict(raw)
    kind = raw.get("model", "quarter_car")
    unknown = set(raw) - {"model", "params", "effects", "inputs", "variations", "maneuver"}
    if unknown:
        raise ScenarioError(f"unknown key(s) {sorted(unknown)} in the vehicle block", source=source)
    if kind not in NOMINAL:
        raise ScenarioError(f"unknown model {kind!r} (diagnose supports {', '.join(NOMINAL)})", source=source,
                            field="model")
    params = {k: v for k, v in (raw.get("params") or {}).items() if k not in IGNORED.get(kind, ())}
    bad = [k for k in params if k not in NOMINAL[kind]]
    if bad:
        raise ScenarioError(f"unknown parameter(s) {bad} for {kind} (known: {', '.join(NOMINAL[kind])})",
                            source=source, field="params")
    P = fs.default_params()
    free, fixed = [], []
    for name, slot in NOMINAL[kind].items():
        is_free, val = (True, None) if name not in params else _is_free(params[name])
        if val is None:
            val = DEFAULTS[kind][name]
        P[slot] = val
        if is_free:
            lo = 1e-6 * max(abs(val), 1e-6) if name in POSITIVE else 0.0
            free.append(FreeParam(name, slot, val, lo, np.inf, max(abs(val), 1e-9)))
        else:
            fixed.append(name)
    if kind == "damper":
        P[fs.MS] = P[fs.MU] = 1.0
    if kind == "sdof":
        P[fs.MU] = 0.0
    effects = []
    for i, e in enumerate(raw.get("effects") or []):
        et = e.get("type") if isinstance(e, dict) else None
        if et not in EFFECT_SLOTS:
            raise ScenarioError(f"effect {et!r} cannot be diagnosed (known: {', '.join(EFFECT_SLOTS)})",
                                source=source, field=f"effects.{i}.type")
        ep = {**EFFECT_DEFAULTS.get(et, {}), **(e.get("params") or {})}
        if et == "tire_liftoff":
            P[fs.LIFT] = 1.0
        for pn, val in ep.items():
            if et == "coulomb_friction" and pn == "law":
                if val != "tanh":
                    raise ScenarioError("diagnose models Coulomb friction with the tanh law (give law: tanh and "
                                        "v_eps)", source=source, field=f"effects.{i}.params.law")
                continue
            if pn not in EFFECT_SLOTS[et]:
                raise ScenarioError(f"parameter {pn!r} of {et} is not supported here", source=source,
                                    field=f"effects.{i}.params.{pn}")
            is_free, v = _is_free(val)
            P[EFFECT_SLOTS[et][pn]] = 0.0 if v is None else v
            if is_free:
                free.append(FreeParam(f"{et}.{pn}", EFFECT_SLOTS[et][pn], P[EFFECT_SLOTS[et][pn]], 0.0, np.inf,
                                      max(abs(P[EFFECT_SLOTS[et][pn]]), 1e-6)))
        effects.append(et)
    inputs = raw.get("inputs") or {}
    for name, slot, default in (("force_gain", fs.GAIN, 1.0), ("force_offset", fs.OFFS, "free")):
        val = inputs.get(name, default)
        is_free, v = _is_free(val)
        P[slot] = default if (v is None and not isinstance(default, str)) else (v or 0.0)
        if is_free:
            free.append(FreeParam(name, slot, P[slot], -np.inf if name == "force_offset" else 1e-6, np.inf, 1.0))
    return ModelSpec(kind, P, free, effects, fixed, source or "", raw)
