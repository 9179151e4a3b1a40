"""Strict values: what pydantic's lax mode would silently convert is an error here.

Pydantic (lax) turns ``true`` into 1.0 for a number field, ``"10"`` into 10, ``1`` or ``"yes"`` into
``True`` for a flag, and accepts ``.inf``/``.nan``.  A scenario that says ``sprung_mass: true`` then runs
as a 1 kg car.  :func:`check` compares the raw input with the validated model, field by field (nested
models, lists and mappings too), and raises a one-line :class:`~suspension_sim.errors.ScenarioError`
naming the field for: a boolean where a number is expected, a string converted to a number or a flag, a
number converted to a flag, and a non-finite number anywhere.  (Pydantic's strict mode cannot be used as
is: YAML gives lists where the models take tuples.)
"""
from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel

from .errors import ScenarioError


def _num(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_bool(v) -> bool:
    import numpy as np

    return isinstance(v, (bool, np.bool_))  # numpy's bool too


def problem(raw: Any, val: Any) -> str | None:
    """What is wrong with ``raw`` having become ``val`` (None if nothing)."""
    if _is_bool(raw):
        if _num(val):
            return f"expects a number, got the boolean {str(raw).lower()}"
        return None
    if isinstance(val, bool):
        if not _is_bool(raw):
            return f"expects true or false, got {raw!r}"
        return None
    if _num(val) and isinstance(raw, str):
        return f"expects a number, got the string {raw!r}"
    if isinstance(val, float) and not math.isfinite(val):
        return f"must be a finite number (got {val!r})"
    if isinstance(raw, float) and not math.isfinite(raw):
        return f"must be a finite number (got {raw!r})"
    return None


def check(raw: Any, val: Any, field: str = "", source: str | None = None) -> None:
    """Raise for the first lax conversion or non-finite number of ``raw`` -> ``val`` (see module doc)."""
    where = _walk(raw, val, field, 0)
    if where is not None:
        f, msg = where
        raise ScenarioError(msg, source=source, field=f or None)


def _walk(raw, val, path, depth):
    if depth > 64:
        return None
    if isinstance(val, BaseModel):
        if isinstance(raw, dict):
            fields = type(val).model_fields
            for k, rv in raw.items():
                if isinstance(k, str) and k in fields:
                    r = _walk(rv, getattr(val, k, None), _join(path, k), depth + 1)
                    if r:
                        return r
            extra = getattr(val, "model_extra", None) or {}
            for k, rv in raw.items():
                if k in extra:
                    r = _walk(rv, extra[k], _join(path, str(k)), depth + 1)
                    if r:
                        return r
        return None
    p = problem(raw, val)
    if p:
        return path, p
    if isinstance(raw, (list, tuple)) and isinstance(val, (list, tuple)) and len(raw) == len(val):
        for i, (rv, vv) in enumerate(zip(raw, val)):
            r = _walk(rv, vv, _join(path, str(i)), depth + 1)
            if r:
                return r
    elif isinstance(raw, dict) and isinstance(val, dict):
        for k, rv in raw.items():
            if k in val:
                r = _walk(rv, val[k], _join(path, str(k)), depth + 1)
                if r:
                    return r
    elif isinstance(raw, (list, tuple, dict)) and val is raw:
        pass
    return None


def check_raw_finite(raw: Any, field: str = "", source: str | None = None) -> None:
    """Refuse any non-finite number in a raw (untyped) structure."""
    def walk(x, path, depth):
        if depth > 64:
            return None
        if isinstance(x, float) and not math.isfinite(x):
            return path
        if isinstance(x, dict):
            for k, v in x.items():
                r = walk(v, _join(path, str(k)), depth + 1)
                if r is not None:
                    return r
        elif isinstance(x, (list, tuple)):
            for i, v in enumerate(x):
                r = walk(v, _join(path, str(i)), depth + 1)
                if r is not None:
                    return r
        return None

    r = walk(raw, field, 0)
    if r is not None:
        raise ScenarioError("must be a finite number (got a NaN or infinity)", source=source, field=r or None)


def _join(a: str, b: str) -> str:
    return f"{a}.{b}" if a else b
