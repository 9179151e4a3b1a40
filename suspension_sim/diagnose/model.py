"""The model being diagnosed: nominal parameters (fixed or free), known effects, where the position sensors
are zeroed, and the named parameter values that :mod:`.engine` simulates.

MODEL.yaml is the ``vehicle`` block of a scenario (``model``, ``params``, ``effects``), or a whole scenario
with one.  Any registered vehicle model can be diagnosed (``suspension-sim list models``), and ``model:
damper`` describes a force element alone (params ``spring_stiffness``, ``damping``).

- A parameter is *free* (calibrated) when it is absent, written ``free`` (or ``?``), or written as
  ``{value: 2.1, free: true}``; a plain number is known and fixed.  Geometry (axle distances, tracks, c.g.
  height: what MuJoCo cannot change without rebuilding the car) is fixed at the model's default when absent;
  write ``free`` to fit it.
- Bounds: a free parameter given with a value stays within ``bounds_factor`` (default 3) of it, both ways;
  a stated-known parameter that the search frees (``parameter:<name>``) too.  ``{value, free, lo, hi}``
  widens or narrows them.  Masses, inertias and stiffnesses stay positive.
- ``inputs: {force_gain: 1.0, force_offset: free}``: the actuator force is ``gain·u + offset`` of the
  measured force input (by default the gain is 1 and the offset is free when a force input is measured).
- ``position_zero: nominal | measured`` (default ``nominal``): where the position sensors (travel, body and
  wheel position, pitch, roll) read zero.  ``nominal``: at the nominal model's ride height, so a heavier
  car shows as sag and a mass can be named from it; ``measured``: at the car's actual ride height (each
  position channel then gets a free offset).  Other channels (accelerations, rates, forces) always get a
  free offset (sensor bias); ``offsets: false`` switches that off.
- ``effects``: known effects, each with ``type``, ``corners`` (default all) and ``params`` (free ones as
  above).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ScenarioError
from ..registry import EFFECTS, VEHICLES

DAMPER_DEFAULTS = {"spring_stiffness": 0.0, "damping": 1000.0}
POSITIVE_WORDS = ("mass", "inertia", "tire_stiffness")
POSITION_CHANNELS = ("susp_travel", "body_pos", "wheel_pos", "pos", "pitch", "roll")


def is_position(channel: str) -> bool:
    """A channel whose zero is the ride height (``position_zero``): travels, body and wheel positions, the
    SDOF's position, pitch and roll angles; not their rates or accelerations (``pitch_rate`` used to match
    the prefix ``pitch``: a pitch gyro's bias was not fitted under ``position_zero: nominal``, while the roll
    gyro's was)."""
    return channel in ("pitch", "roll") or any(channel.startswith(p) for p in POSITION_CHANNELS[:4])


@dataclass
class FreeParam:
    """A fitted parameter: its ``name`` (the key of the parameter dict), start, bounds and scale."""

    name: str
    init: float
    lo: float = -np.inf
    hi: float = np.inf
    scale: float = 1.0
    size: bool = False  # measures the strength of an added effect (pruned when indistinguishable from 0)
    unseen: float | None = None  # the value when the fitted window does not determine it (FreeParameter.unseen)
    # a signed difference of two non-negative parameters (positive part, negative part): the value v sets the
    # first to max(v, 0) and the second to max(−v, 0) (an effect beside the linear element it contains)
    split: tuple | None = None


@dataclass
class EffectEntry:
    label: str  # unique name in the model ("bump_stop", "bump_stop@front")
    type: str  # registered effect
    corners: object = "all"  # "all" or a list of corner names
    fixed: dict = field(default_factory=dict)  # non-numeric / fixed settings


@dataclass
class ModelSpec:
    kind: str
    P: dict  # every numeric parameter by name (vehicle, "<label>.<param>", "actuator.time_constant", "input.*")
    free: list[FreeParam]
    effects: list[EffectEntry] = field(default_factory=list)
    fixed_nominal: list[str] = field(default_factory=list)  # vehicle params the model says are known
    source: str = ""
    raw: dict = field(default_factory=dict)
    position_zero: str = "nominal"
    offsets: bool = True
    bounds_factor: float = 3.0
    lag: bool = False  # the actuator lag is part of the model
    level: dict = field(default_factory=dict)  # masses the car was levelled with, when not its own (levelled_with)
    # a free gain on every output channel (sensor calibration factors, relative to the measured inputs' scale;
    # eliminated in closed form per channel like the offsets): select.py rule (h), the sensor-gain rival
    gains: bool = False

    def copy(self) -> "ModelSpec":
        return ModelSpec(self.kind, dict(self.P), [copy.copy(f) for f in self.free],
                         [copy.deepcopy(e) for e in self.effects], list(self.fixed_nominal), self.source,
                         copy.deepcopy(self.raw), self.position_zero, self.offsets, self.bounds_factor, self.lag,
                         dict(self.level), self.gains)

    def vector(self, x) -> dict:
        P = dict(self.P)
        for f, v in zip(self.free, x):
            P[f.name] = float(v)
            if f.split is not None:
                P[f.split[0]], P[f.split[1]] = max(float(v), 0.0), max(-float(v), 0.0)
        return P

    @property
    def x0(self) -> np.ndarray:
        return np.array([f.init for f in self.free], float)

    def names(self) -> list[str]:
        return [f.name for f in self.free]

    @property
    def effect_types(self) -> list[str]:
        return [e.label for e in self.effects]

    def structure(self) -> tuple:
        return tuple((e.label, e.type, e.corners if e.corners == "all" else tuple(e.corners),
                      tuple(sorted(e.fixed.items()))) for e in self.effects) + (("lag", self.lag),)


def vehicle_params(kind: str) -> dict[str, float]:
    """Numeric vehicle parameters and defaults of a model kind."""
    if kind == "damper":
        return dict(DAMPER_DEFAULTS)
    vcls = VEHICLES.get(kind)
    out = {}
    for k, v in vcls.Params().model_dump().items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[k] = float(v)
    return out


def positive(name: str) -> bool:
    return any(w in name for w in POSITIVE_WORDS) or name in ("a", "b") or name.startswith("track")


def nominal_bounds(name: str, val: float, factor: float) -> tuple[float, float]:
    """Physical bounds of a vehicle parameter stated with value ``val``: within ``factor`` of it."""
    if val > 0:
        return val / factor, val * factor
    if val < 0:
        return val * factor, val / factor
    return 0.0, np.inf


def _zero_scale(lo: float, hi: float) -> float:
    """Scale of a free parameter stated as 0 (no data scale yet): from its declared bounds, else 1 (SI).  The
    scale sets the finite-difference step; a scale of 1e-9 (the former floor) left the parameter at 0."""
    if np.isfinite(hi) and hi > max(lo, 0.0):
        return float(hi - max(lo, 0.0)) / 2.0 if np.isfinite(lo) else float(abs(hi))
    return 1.0


def _is_free(v) -> tuple[bool, float | None, dict]:
    if isinstance(v, str) and v.strip().lower() in ("free", "?"):
        return True, None, {}
    if isinstance(v, dict):
        val = v.get("value")
        extra = {k: float(v[k]) for k in ("lo", "hi") if v.get(k) is not None}
        return bool(v.get("free", False)), (None if val is None else float(val)), extra
    if isinstance(v, bool):
        raise ScenarioError(f"parameter value {v!r} is not a number, 'free' or {{value, free}}")
    try:
        return False, float(v), {}
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
    nested = "vehicle" in raw and isinstance(raw["vehicle"], dict)
    if nested:
        extra = {k: raw[k] for k in ("inputs", "position_zero", "offsets", "bounds_factor") if k in raw}
        raw = {**dict(raw["vehicle"]), **extra}
    raw = dict(raw)
    kind = raw.get("model", "quarter_car")
    unknown = set(raw) - {"model", "params", "effects", "inputs", "variations", "maneuver", "position_zero",
                          "offsets", "bounds_factor", "levelled_with"}
    if unknown:
        raise ScenarioError(f"unknown key(s) {sorted(unknown)} in the vehicle block", source=source)
    if kind != "damper" and kind not in VEHICLES.names():
        raise ScenarioError(f"unknown model {kind!r} (diagnose supports {', '.join(VEHICLES.names())} and damper)",
                            source=source, field="model")
    pz = raw.get("position_zero", "nominal")
    if pz not in ("nominal", "measured"):
        raise ScenarioError("position_zero must be 'nominal' or 'measured'", source=source, field="position_zero")
    factor = float(raw.get("bounds_factor", 3.0))
    if not factor > 1:
        raise ScenarioError("bounds_factor must be > 1", source=source, field="bounds_factor")
    defaults = vehicle_params(kind)
    from .engine import writable_params

    writable = writable_params(kind)
    params = raw.get("params") or {}
    if not isinstance(params, dict):
        raise ScenarioError("params must be a mapping", source=source, field="params")
    bad = [k for k in params if k not in defaults]
    if bad:
        raise ScenarioError(f"unknown parameter(s) {bad} for {kind} (known: {', '.join(defaults)})",
                            source=source, field="params")
    P: dict = {}
    free, fixed = [], []
    for name, dv in defaults.items():
        if name in params:
            is_free, val, ex = _is_free(params[name])
        else:
            is_free, val, ex = (name in writable), None, {}
        stated = val is not None
        val = dv if val is None else val
        if is_free and val <= 0 and positive(name):
            val = dv
        P[name] = val
        if is_free:
            if stated:
                lo, hi = nominal_bounds(name, val, factor)
            else:
                lo, hi = (1e-6 * max(abs(val), 1e-12), np.inf) if positive(name) else (0.0, np.inf)
            lo, hi = ex.get("lo", lo), ex.get("hi", hi)
            free.append(FreeParam(name, val, lo, hi, abs(val) if val != 0 else _zero_scale(lo, hi)))
        else:
            fixed.append(name)
    effects = []
    for i, e in enumerate(raw.get("effects") or []):
        et = e.get("type") if isinstance(e, dict) else None
        ecls = EFFECTS.get(et, field=f"effects.{i}.type", source=source) if isinstance(et, str) else None
        if ecls is None:
            raise ScenarioError(f"effect {et!r} is not a registered effect", source=source, field=f"effects.{i}.type")
        label = e.get("label", et if all(x.label != et for x in effects) else f"{et}#{i}")
        corners = e.get("corners", "all")
        ent = EffectEntry(label, et, corners, {})
        fields = ecls.Params.model_fields
        for pn, v in (e.get("params") or {}).items():
            if pn not in fields:
                raise ScenarioError(f"parameter {pn!r} of {et} is not known (known: {', '.join(fields)})",
                                    source=source, field=f"effects.{i}.params.{pn}")
            numeric = isinstance(v, (int, float)) and not isinstance(v, bool)
            if not (numeric or isinstance(v, dict) or (isinstance(v, str) and v.strip().lower() in ("free", "?"))):
                ent.fixed[pn] = v  # a setting (law, table, flag)
                continue
            is_free, val, ex = _is_free(v)
            default = fields[pn].default
            val = float(default if val is None and isinstance(default, (int, float)) else (val or 0.0))
            P[f"{label}.{pn}"] = val
            if is_free:
                free.append(FreeParam(f"{label}.{pn}", val, ex.get("lo", 0.0), ex.get("hi", np.inf),
                                      max(abs(val), 1e-6)))
        effects.append(ent)
    inputs = raw.get("inputs") or {}
    for name, key, default in (("force_gain", "input.gain", 1.0), ("force_offset", "input.offset", "free")):
        val = inputs.get(name, default)
        is_free, v, _ = _is_free(val)
        P[key] = default if (v is None and not isinstance(default, str)) else (v or 0.0)
        if is_free:
            free.append(FreeParam(key, P[key], -np.inf if name == "force_offset" else 1e-6, np.inf, 1.0))
    level = raw.get("levelled_with") or {}
    if level:  # (a fitted model written back: the masses its nominal ride height carries)
        from ..vehicles.base import levelled_params

        vehicle = "vehicle." if nested else ""  # fields as the file has them (a scenario's vehicle block too)
        levelled_params(VEHICLES.get(kind) if kind != "damper" else None, {k: P[k] for k in defaults}, level,
                        source, field=f"{vehicle}levelled_with", model=kind, params_field=f"{vehicle}params")
    return ModelSpec(kind, P, free, effects, fixed, source or "", raw, pz, bool(raw.get("offsets", True)), factor,
                     level={k: float(v) for k, v in level.items()})
