"""Scenario files: YAML validated by pydantic into a :class:`Scenario`.

A scenario names everything a run needs::

    name: quickstart
    vehicle:  {model: quarter_car, params: {...}, effects: [...], variations: [...]}
    road:     {type: iso8608, params: {road_class: C}, speed: 20}
    sensors:  [{name: corner_body_vel, type: corner_body_vel, rate: 1000, noise_std: 0.001}]
    actuator: {type: ideal, params: {max_force: 4000}}
    controller: {type: skyhook, params: {c_sky: 2500}}
    sim:      {duration: 10, dt: 0.0005, control_dt: 0.001, log_dt: 0.001, seed: 1}
    outputs:  {timeseries: true, plots: true}
    variants: {passive: {controller: {type: passive}}, skyhook: {}}

Unknown keys and bad values raise :class:`~suspension_sim.errors.ScenarioError` with a one-line message
naming the file and the field.  ``--set path.to.key=value`` overrides are applied to the raw YAML before
validation, with the value parsed as YAML.
"""
from __future__ import annotations

import copy
import hashlib
import json
from pathlib import Path
from typing import Any, Literal, Optional, Union

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from .components import format_validation_error, validate_params
from .errors import ScenarioError


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class EffectCfg(_Strict):
    type: str
    corners: Union[Literal["all"], list[str]] = "all"
    params: dict[str, Any] = Field(default_factory=dict)


class VariationCfg(_Strict):
    """A time-varying vehicle parameter (the thesis's parameter variations, mode I).

    ``param`` is a vehicle parameter name (e.g. ``sprung_mass``, ``spring_stiffness``, ``damping``), or a plant
    effect's numeric parameter addressed as ``effects.<label>.<param>`` by the effect's log label (its type, and
    ``<type>#2``, ``#3``, ... for a second, third effect of the same type: e.g. ``effects.quadratic_damping.c_v``,
    ``effects.bump_stop#2.stiffness``; ``corners`` then selects among the effect's corners);
    ``mode`` says how ``values`` combine with the nominal value (``add``, ``scale`` or ``set``).
    ``kind``: ``step`` (value i holds from times[i]), ``ramp`` (linear between (times, values) points),
    ``sine`` (values = [amplitude, frequency_hz, phase_rad], offset 0 in the given mode).
    """

    param: str
    kind: Literal["step", "ramp", "sine"] = "step"
    mode: Literal["add", "scale", "set"] = "add"
    times: list[float] = Field(default_factory=list)
    values: list[float]
    corners: Union[Literal["all"], list[str]] = "all"


class ComponentCfg(_Strict):
    type: str
    params: dict[str, Any] = Field(default_factory=dict)


class VehicleCfg(_Strict):
    """``levelled_with``: masses and inertias (vehicle parameter names) the car was levelled with, when they are
    not its ``params``: the springs carry *those* weights at zero travel (the ride height where positions read
    zero), and the car, heavier or lighter, starts at rest where its springs and suspension effects carry its
    own weight (:mod:`suspension_sim.statics`): a load added without re-levelling shows as sag, and a stop's
    gap or a cubic spring's zero stays where it is on the car.  Empty (the default): levelled with ``params``."""

    model: str = "quarter_car"
    params: dict[str, Any] = Field(default_factory=dict)
    levelled_with: dict[str, Any] = Field(default_factory=dict)
    effects: list[EffectCfg] = Field(default_factory=list)
    variations: list[VariationCfg] = Field(default_factory=list)
    maneuver: Optional[ComponentCfg] = None


class RoadCfg(_Strict):
    type: str
    params: dict[str, Any] = Field(default_factory=dict)
    speed: Union[float, list[tuple[float, float]]] = Field(
        20.0, description="vehicle speed in m/s, constant or a list of [time, speed] points (linear)")
    seed: Optional[int] = Field(None, ge=0, description="road seed (default: sim.seed)")
    tracks: Literal["same", "independent"] = "same"

    @field_validator("speed")
    @classmethod
    def _speed(cls, v):
        if isinstance(v, (int, float)):
            if v < 0:
                raise ValueError("speed must be >= 0")
        else:
            if len(v) < 1:
                raise ValueError("speed table needs at least one [time, speed] point")
            ts = [p[0] for p in v]
            if any(b <= a for a, b in zip(ts, ts[1:])):
                raise ValueError("speed table times must increase")
            if any(p[1] < 0 for p in v):
                raise ValueError("speeds must be >= 0")
        return v


class SensorCfg(_Strict):
    name: Optional[str] = None
    type: str
    rate: Optional[float] = Field(None, gt=0, description="sample rate in Hz (default: control rate)")
    noise_std: float = Field(0.0, ge=0)
    bias: float = 0.0
    delay: float = Field(0.0, ge=0, description="pure delay in s (rounded to control steps)")
    quantization: float = Field(0.0, ge=0, description="quantisation step (0 = none)")
    params: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _name(self):
        if not self.name:
            self.name = self.type
        return self


class ControllerCfg(_Strict):
    type: str = "passive"
    params: dict[str, Any] = Field(default_factory=dict)
    full_state: bool = Field(False, description="give the controller the simulator's true state (reported)")


class SimCfg(_Strict):
    duration: float = Field(10.0, gt=0)
    dt: float = Field(0.0005, gt=0, le=0.01, description="physics step in s")
    control_dt: float = Field(0.001, gt=0, description="control step in s (a multiple of dt)")
    log_dt: float = Field(0.001, gt=0, description="logging step in s (a multiple of dt)")
    seed: int = Field(0, ge=0)
    integrator: Literal["auto", "implicitfast", "trapezoidal", "RK4"] = Field(
        "auto", description="MuJoCo integrator: auto (default: trapezoidal wherever it applies and is stable, "
        "else implicitfast; the choice and why are written into scenario.resolved.yaml); implicitfast (dampers "
        "implicit, robust for stiff elements, first order: ~w*dt/2 phase lag); trapezoidal (MuJoCo's implicitfast step with the linear "
        "dampers split half implicit, half explicit, and the body-wheel damper coupling that MuJoCo's implicit "
        "step leaves out supplied from the last step: second order at the same cost; needs damping*dt/mass <= 1 "
        "and a model with tires); or RK4 (4th order for the linear plant; 3.5x the cost). Effect and actuator "
        "forces are held over each step in all three (first order in the step for a force that moves within it; "
        "coulomb_friction, bump_stop and quadratic_damping offer step_force: mean, their mean over the step)")
    max_displacement: float = Field(5.0, gt=0, description="divergence guard on |position| in m (or rad)")
    max_velocity: float = Field(200.0, gt=0, description="divergence guard on |velocity| in m/s")

    @field_validator("control_dt", "log_dt")
    @classmethod
    def _multiple_of_dt(cls, v, info):  # a field validator, so that the error names sim.control_dt / sim.log_dt
        dt = info.data.get("dt")
        if dt is not None:
            r = v / dt
            if abs(r - round(r)) > 1e-6 or round(r) < 1:
                raise ValueError(f"must be a whole multiple of dt={dt}")
        return v

    @model_validator(mode="after")
    def _sizes(self):  # before anything is allocated: a run must have a step, and fit the limits
        from . import limits

        if not (self.duration < float("inf")):
            return self  # reported as non-finite by the strict check
        if self.duration < self.dt * (1 - 1e-9):
            raise ValueError(f"duration={self.duration:g} s is shorter than one physics step dt={self.dt:g} s")
        if self.duration < self.log_dt * (1 - 1e-9):
            raise ValueError(f"duration={self.duration:g} s is shorter than one logging step log_dt={self.log_dt:g} s")
        limits.check("steps", self.duration / self.dt)
        limits.check("log_samples", self.duration / self.log_dt)
        return self


class OutputsCfg(_Strict):
    timeseries: bool = True
    plots: bool = True
    viewer: bool = False
    report: bool = False


class Scenario(_Strict):
    name: str = "scenario"
    description: str = ""
    notes: str = Field("", description="free text: sources, reconstructions, chosen constants")
    vehicle: VehicleCfg = Field(default_factory=VehicleCfg)
    road: RoadCfg
    sensors: list[SensorCfg] = Field(default_factory=list)
    actuator: ComponentCfg = Field(default_factory=lambda: ComponentCfg(type="ideal"))
    controller: ControllerCfg = Field(default_factory=ControllerCfg)
    sim: SimCfg = Field(default_factory=SimCfg)
    outputs: OutputsCfg = Field(default_factory=OutputsCfg)
    variants: dict[str, dict[str, Any]] = Field(default_factory=dict)

    # -- derived -------------------------------------------------------------------------------------
    def resolved_dict(self) -> dict:
        return self.model_dump(mode="json")

    def hash(self) -> str:
        d = self.resolved_dict()
        d.pop("outputs", None)
        return hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]

    def expand(self, source: str | None = None) -> list[tuple[str, "Scenario"]]:
        """The scenario's variants as resolved scenarios (itself alone when it has none)."""
        if not self.variants:
            return [(self.name, self)]
        base = self.model_dump(mode="json")
        base.pop("variants")
        out = []
        for vname, over in self.variants.items():
            raw = deep_merge(copy.deepcopy(base), over or {})
            raw["name"] = f"{self.name}/{vname}" if self.name else vname
            out.append((vname, parse_scenario(raw, source=source, field_prefix=f"variants.{vname}")))
        return out


def pick_variant(sc: Scenario, variant: str | None, source: str | None = None) -> Scenario:
    """The scenario of one variant (``variant`` None: the scenario itself, which must then have no variants)."""
    variants = dict(sc.expand(source))
    if variant is not None:
        if variant not in variants:
            raise ScenarioError(f"no variant {variant!r} (has: {', '.join(variants)})", source=source, field="variants")
        return variants[variant]
    if sc.variants:
        raise ScenarioError(f"the scenario has variants ({', '.join(variants)}): pass variant=<name>",
                            source=source, field="variants")
    return sc


def deep_merge(base: dict, over: dict) -> dict:
    """Merge a variant's overrides into the base scenario. A component whose ``type`` changes is replaced
    whole (its old params would not fit the new type); ``params`` of the same type are updated key by key."""
    for k, v in over.items():
        if (isinstance(v, dict) and isinstance(base.get(k), dict) and "type" in v
                and v["type"] != base[k].get("type")):
            base[k] = v
        elif isinstance(v, dict) and isinstance(base.get(k), dict) and k != "params":
            deep_merge(base[k], v)
        elif isinstance(v, dict) and isinstance(base.get(k), dict) and k == "params":
            base[k] = {**base[k], **v}
        else:
            base[k] = v
    return base


def apply_set(raw: dict, assignment: str, source: str | None = None) -> dict:
    """Apply one ``path.to.key=value`` override (value parsed as YAML) to a raw scenario dict."""
    if "=" not in assignment:
        raise ScenarioError(f"--set expects path.to.key=value, got {assignment!r}", source=source)
    path, _, text = assignment.partition("=")
    from .safeyaml import loads

    try:
        value = loads(text, source=source, field=f"--set {path.strip()}")
    except ScenarioError as err:
        if "not valid YAML" not in str(err):
            raise  # a limit (alias bomb, depth): never fall back to the text
        value = text
    keys = path.strip().split(".")
    if not all(keys):
        raise ScenarioError(f"--set has an empty key in {path!r}", source=source)
    vs = raw.get("variants") if isinstance(raw.get("variants"), dict) else {}
    if keys[0] == "variants" and len(keys) > 2 and keys[1] not in vs:
        known = ", ".join(map(str, vs)) or "none"  # a misspelt name would make a new variant
        raise ScenarioError(f"--set: unknown variant {keys[1]!r} (the scenario has: {known}; to add a variant "
                            f"set it whole: --set variants.{keys[1]}={{...}})", source=source, field=path.strip())
    node: Any = raw
    for i, k in enumerate(keys[:-1]):
        if isinstance(node, list):
            try:
                node = node[int(k)]
            except (ValueError, IndexError):
                raise ScenarioError(f"--set: no list item {k!r}", source=source, field=".".join(keys[: i + 1])) from None
            continue
        if k not in node or node[k] is None:
            node[k] = {}
        if not isinstance(node[k], (dict, list)):
            raise ScenarioError(f"--set: {k!r} is not a mapping", source=source, field=".".join(keys[: i + 1]))
        node = node[k]
    last = keys[-1]
    if isinstance(node, list):
        try:
            node[int(last)] = value
        except (ValueError, IndexError):
            raise ScenarioError(f"--set: no list item {last!r}", source=source, field=path) from None
    else:
        node[last] = value
    return raw


def read_yaml(path: str | Path, what: str = "scenario file") -> dict:
    """A YAML mapping from a user's file, read safely (:mod:`suspension_sim.safeyaml`: size, alias-expansion and
    depth limits, UTF-8 only, duplicate keys refused)."""
    from .safeyaml import load_file

    raw = load_file(path, what)
    if not isinstance(raw, dict):
        raise ScenarioError("a scenario must be a YAML mapping", source=str(path))
    return raw


def parse_scenario(raw: dict, source: str | None = None, field_prefix: str = "") -> Scenario:
    from .strict import check as strict_check

    try:
        sc = Scenario.model_validate(raw)
        strict_check(raw, sc)
    except ValidationError as err:
        field, msg = format_validation_error(err)
        if field_prefix:
            field = f"{field_prefix}:{field}"
        raise ScenarioError(msg, source=source, field=field) from None
    except ScenarioError as err:  # a lax conversion (true for a number, "10", .inf): name the field
        field = f"{field_prefix}:{err.field}" if field_prefix else err.field
        msg = str(err)[len(err.field) + 2:] if err.field and str(err).startswith(err.field + ": ") else str(err)
        raise ScenarioError(msg, source=source, field=field) from None
    try:
        check_components(sc, source)
    except ScenarioError as err:
        if not field_prefix:
            raise
        head = ": ".join(str(x) for x in (err.source, err.field) if x)  # re-raise naming the variant too
        msg = str(err)[len(head) + 2:] if head and str(err).startswith(head + ": ") else str(err)
        raise ScenarioError(msg, source=err.source or source,
                            field=f"{field_prefix}:{err.field}" if err.field else field_prefix) from None
    return sc


def load_scenario(path: str | Path, overrides: list[str] | None = None) -> Scenario:
    """Read, override (``path.to.key=value`` strings) and validate a scenario file."""
    raw = read_yaml(path)
    for s in overrides or []:
        apply_set(raw, s, source=str(path))
    sc = parse_scenario(raw, source=str(path))
    sc.expand(source=str(path))  # validate the variants too
    return sc


def check_components(sc: Scenario, source: str | None = None) -> None:
    """Resolve every named component and validate its parameters (errors name the field)."""
    from .registry import ACTUATORS, CONTROLLERS, EFFECTS, ROADS, SENSORS, VEHICLES

    vcls = VEHICLES.get(sc.vehicle.model, field="vehicle.model", source=source)
    vparams = validate_params(vcls.Params, sc.vehicle.params, "vehicle.params", source)
    corners = vcls.corner_names(vparams)
    if sc.vehicle.levelled_with:
        from .vehicles.base import levelled_params

        levelled_params(vcls, sc.vehicle.params, sc.vehicle.levelled_with, source, model=sc.vehicle.model)
    for i, e in enumerate(sc.vehicle.effects):
        ecls = EFFECTS.get(e.type, field=f"vehicle.effects.{i}.type", source=source)
        validate_params(ecls.Params, e.params, f"vehicle.effects.{i}.params", source)
        _check_corners(e.corners, corners, f"vehicle.effects.{i}.corners", source)
    labels = effect_labels([e.type for e in sc.vehicle.effects])
    for i, v in enumerate(sc.vehicle.variations):
        if v.param.startswith(EFFECT_PREFIX):
            _check_effect_variation(sc, labels, corners, v, i, source)
        elif v.param not in vcls.Params.model_fields:
            raise ScenarioError(f"unknown vehicle parameter {v.param!r} (known: {', '.join(vcls.Params.model_fields)})",
                                source=source, field=f"vehicle.variations.{i}.param")
        elif v.corners != "all":
            _check_corners(v.corners, corners, f"vehicle.variations.{i}.corners", source)
            _check_vehicle_variation_corners(vcls, vparams, corners, v, i, source)
        if v.kind in ("step", "ramp") and len(v.times) != len(v.values):
            raise ScenarioError("times and values must have the same length", source=source,
                                field=f"vehicle.variations.{i}")
        if v.kind == "sine" and len(v.values) not in (2, 3):
            raise ScenarioError("sine variation needs values [amplitude, frequency_hz(, phase)]", source=source,
                                field=f"vehicle.variations.{i}.values")
    if sc.vehicle.maneuver is not None:
        from .maneuvers import MANEUVERS

        mcls = MANEUVERS.get(sc.vehicle.maneuver.type, field="vehicle.maneuver.type", source=source)
        validate_params(mcls.Params, sc.vehicle.maneuver.params, "vehicle.maneuver.params", source)
    rcls = ROADS.get(sc.road.type, field="road.type", source=source)
    validate_params(rcls.Params, sc.road.params, "road.params", source)
    names = set()
    for i, s in enumerate(sc.sensors):
        scls = SENSORS.get(s.type, field=f"sensors.{i}.type", source=source)
        validate_params(scls.Params, s.params, f"sensors.{i}.params", source)
        if s.name in names:
            raise ScenarioError(f"duplicate sensor name {s.name!r}", source=source, field=f"sensors.{i}.name")
        names.add(s.name)
    acls = ACTUATORS.get(sc.actuator.type, field="actuator.type", source=source)
    validate_params(acls.Params, sc.actuator.params, "actuator.params", source)
    ccls = CONTROLLERS.get(sc.controller.type, field="controller.type", source=source)
    validate_params(ccls.Params, sc.controller.params, "controller.params", source)
    if not sc.controller.full_state:
        missing = [r for r in ccls.required_sensors(sc.controller.params) if r not in names]
        if missing:
            raise ScenarioError(
                f"controller '{sc.controller.type}' needs sensor(s) {', '.join(missing)}: declare them under "
                f"'sensors' (or set controller.full_state: true)", source=source, field="sensors")


EFFECT_PREFIX = "effects."


def effect_labels(types: list[str]) -> list[str]:
    """The log label of each plant effect, in order (``effect.LABEL.SIGNAL.k``, and ``effects.LABEL.PARAM`` in a
    variation): the type, and ``TYPE#2``, ``TYPE#3``, ... for a second, third effect of the same type."""
    seen: dict[str, int] = {}
    out = []
    for t in types:
        seen[t] = seen.get(t, 0) + 1
        out.append(t if seen[t] == 1 else f"{t}#{seen[t]}")
    return out


def effect_variation_target(param: str, labels: list[str], source: str | None = None,
                            field: str | None = None) -> tuple[int, str]:
    """(index of the effect, parameter name) addressed by a variation's ``effects.<label>.<param>``; a
    ScenarioError naming ``source`` and ``field`` when the address is malformed or names no effect."""
    parts = param[len(EFFECT_PREFIX):].split(".")
    if len(parts) != 2 or not all(parts):
        raise ScenarioError(f"an effect parameter is addressed as effects.<label>.<param> (e.g. "
                            f"effects.bump_stop#2.stiffness), got {param!r}", source=source, field=field)
    label, name = parts
    if label not in labels:
        raise ScenarioError(f"no effect labelled {label!r} (this vehicle's effects: {', '.join(labels) or 'none'})",
                            source=source, field=field)
    return labels.index(label), name


def _check_effect_variation(sc, labels, corners, v, i, source) -> None:
    from .registry import EFFECTS

    field = f"vehicle.variations.{i}.param"
    k, name = effect_variation_target(v.param, labels, source, field)
    e = sc.vehicle.effects[k]
    ecls = EFFECTS.get(e.type)
    p = validate_params(ecls.Params, e.params, f"vehicle.effects.{k}.params", source)
    numeric = [f for f, _ in type(p).model_fields.items() if _is_number_or_numbers(getattr(p, f))]
    if name not in numeric:
        raise ScenarioError(f"effect {labels[k]!r} has no numeric parameter {name!r} (can vary: "
                            f"{', '.join(numeric) or 'none'})", source=source, field=field)
    ecorners = corners if e.corners == "all" else list(e.corners)
    _check_corners(v.corners, ecorners, f"vehicle.variations.{i}.corners", source)


def _check_vehicle_variation_corners(vcls, vparams, corners, v, i, source) -> None:
    from .vehicles.base import targets_on_corners

    targets = vcls.variation_targets(vparams).get(v.param)
    if targets is not None and targets_on_corners(targets, list(v.corners), corners) is None:
        raise ScenarioError(f"parameter {v.param!r} does not act on corner(s) {list(v.corners)} (leave corners "
                            "at 'all', or choose a corner this parameter has)", source=source,
                            field=f"vehicle.variations.{i}.corners")


def _is_number_or_numbers(x) -> bool:
    def num(y):
        return isinstance(y, (int, float)) and not isinstance(y, bool)
    return num(x) or (isinstance(x, list) and bool(x) and all(num(y) for y in x))


def _check_corners(sel, corners, field, source):
    if sel == "all":
        return
    bad = [c for c in sel if c not in corners]
    if bad:
        raise ScenarioError(f"unknown corner(s) {bad} (this model has {corners})", source=source, field=field)
