"""Common plumbing of pluggable components (effects, roads, actuators, controllers, sensors).

Every component class declares its parameters as a pydantic model ``Params`` (defaults, units in the
field descriptions, bounds).  Scenario values are validated against it, so a bad value gives a one-line
error naming the field.

Components are vectorised over an *ensemble* of cars (a single run is an ensemble of one).  The parameters
of the cars are stacked by :func:`stack_params`: a scalar becomes an array of shape ``(n_cars, 1)`` and a
per-corner list an array ``(n_cars, n_corners)``, so both broadcast against corner arrays of shape
``(n_cars, n_corners)``.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Any, Iterable

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from .errors import ScenarioError


class NoParams(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Params(BaseModel):
    """Base for component parameter models: unknown keys are errors."""

    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True)


def format_validation_error(err: ValidationError, prefix: str = "") -> tuple[str, str]:
    """(field path, message) of the first error of a pydantic ValidationError.

    Union members' tags in the location (``constrained-float``, ``list[float]``) are dropped, and of the
    alternatives of one union the deepest error is shown (``c_v.1: >= 0`` rather than ``c_v: not a number``)."""
    errs = [(tuple(p for p in x.get("loc", ()) if p != "__root__" and not _union_tag(p)), x) for x in err.errors()]
    first = errs[0][0]
    loc_t, e = max((ex for ex in errs if ex[0][:len(first)] == first), key=lambda ex: len(ex[0]))
    loc = ".".join(str(p) for p in loc_t)
    field = ".".join(p for p in (prefix, loc) if p)
    msg = e.get("msg", "invalid value")
    if e.get("type") == "value_error" and msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]  # our validators' own messages, without pydantic's prefix
    if e.get("type") == "extra_forbidden":
        msg = "unknown key"
    elif e.get("type") == "missing":
        msg = "required field is missing"
    else:
        inp = e.get("input")
        if inp is not None and not isinstance(inp, (dict, list)):
            msg = f"{msg} (got {inp!r})"
    return field, msg


def _union_tag(p) -> bool:
    return isinstance(p, str) and ("[" in p or p.startswith("constrained-") or
                                   p in ("float", "int", "str", "bool", "none", "list", "dict", "tuple"))


def validate_params(model: type[BaseModel], raw: dict | None, field: str, source: str | None = None) -> BaseModel:
    from .strict import check as strict_check

    if raw is not None and not isinstance(raw, dict):
        raise ScenarioError(f"expects a mapping of parameters, got {type(raw).__name__} {raw!r}"[:300],
                            source=source, field=field)
    try:
        out = model.model_validate(raw or {})
    except ValidationError as err:
        f, msg = format_validation_error(err, field)
        raise ScenarioError(msg, source=source, field=f) from None
    strict_check(raw or {}, out, field, source)  # no lax conversions (true -> 1.0, "10" -> 10), finite numbers
    return out


def validate_many(model: type[BaseModel], raws: Iterable, field: str, source: str | None = None) -> list:
    """:func:`validate_params` of each car's raw parameters, each distinct raw mapping validated once (the cars of
    an ensemble mostly share their components' parameters: a 256-car sweep over roads validated the same mappings
    256 times, a fifth of building the ensemble).  Mappings are the same when their keys, values and the values'
    types are (``1`` and ``1.0``, ``0.0`` and ``-0.0``, ``true`` and ``1`` differ); a mapping holding anything but
    YAML's plain types is validated by itself.  Cars with the same mapping share one (read-only) model instance;
    errors are those of validating the first car that has the bad mapping."""
    out, memo = [], {}
    for raw in raws:
        key = _plain_key(raw)
        if key is None:
            out.append(validate_params(model, raw, field, source))
            continue
        if key not in memo:
            memo[key] = validate_params(model, raw, field, source)
        out.append(memo[key])
    return out


def _plain_key(x, depth: int = 0):
    """A hashable key of a YAML-like value that tells apart every two values a validation could tell apart (types,
    the sign of zero, key order), or None for anything else (then nothing is shared)."""
    t = type(x)
    if x is None or t is bool or t is int or t is str:
        return (t.__name__, x)
    if t is float:
        return ("float", x.hex()) if x == x else None  # hex keeps -0.0 apart from 0.0; NaN is never shared
    if depth > 32:
        return None
    if t is dict:
        items = []
        for k, v in x.items():
            kk, kv = _plain_key(k, depth + 1), _plain_key(v, depth + 1)
            if kk is None or kv is None:
                return None
            items.append((kk, kv))
        return ("dict", tuple(items))
    if t is list or t is tuple:
        vals = tuple(_plain_key(v, depth + 1) for v in x)
        return None if any(v is None for v in vals) else (t.__name__, vals)
    return None


def stack_params(params: Iterable[BaseModel], n_corners: int) -> SimpleNamespace:
    """Stack the validated parameters of each car into arrays (see module docstring)."""
    params = list(params)
    out: dict[str, Any] = {}
    if not params:
        return SimpleNamespace()
    def is_num(v):
        return isinstance(v, (int, float)) and not isinstance(v, bool)

    def is_corner_list(v):
        return isinstance(v, (list, tuple)) and len(v) == n_corners and all(is_num(x) for x in v)

    for key in type(params[0]).model_fields:
        vals = [getattr(p, key) for p in params]
        v0 = vals[0]
        if all(is_num(v) for v in vals):
            out[key] = np.asarray(vals, dtype=float).reshape(-1, 1)
        elif all(is_num(v) or is_corner_list(v) for v in vals):
            # per-corner lists, possibly mixed with scalars (one value for every corner) across the cars
            out[key] = np.asarray([[float(v)] * n_corners if is_num(v) else list(v) for v in vals], dtype=float)
        else:
            # flags, strings, None, tables: one value if all cars agree, else the list of per-car values
            out[key] = v0 if all(v == v0 for v in vals) else vals
    return SimpleNamespace(**out)


def scalar(value) -> float:
    """The single value of a stacked parameter (for quantities that must be equal over the ensemble)."""
    a = np.asarray(value, dtype=float)
    if a.size and not np.all(a == a.flat[0]):
        raise ValueError("parameter differs across the ensemble where one value is required")
    return float(a.flat[0])
