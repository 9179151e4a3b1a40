"""The thesis's Parametric variations mode I drifts (Sec. 2.3.1, Figs. 2.7–2.8), defined once.

The thesis shows, as figures without numbers, "a gradual change of air spring stiffness with temperature and
blow-off of the shock absorber valves" and uses them "for the purpose of testing the adaptive capabilities of
the controller".  Their size and timing are not recoverable from the text, so they are ours, stated here and
nowhere else (the scenario files carry them as ``vehicle.variations`` entries with ``mode: scale``, and
``tests/test_thesis_drift.py`` checks every thesis scenario that uses them against this module):

- stiffness: every spring −15 %, linearly from T/6 to 5T/6 of a run of length T (60 s: from 10 s to 50 s);
- damping: every linear damper −40 % in T/100 at T/2 (60 s: in 0.6 s at 30 s), a valve blow-off.

A velocity-squared damper is a plant *effect*, which ``vehicle.variations`` (MjModel fields) cannot reach;
where a chapter's damper is one (Ch. 7, the Ch. 6 primary) only the linear dampers drift, and the page says so.
"""
from __future__ import annotations

STIFFNESS_DROP = 0.15
DAMPING_DROP = 0.40


def stiffness_drift(duration: float) -> dict:
    """(times, scale values) of the spring drift for a run of ``duration`` seconds (``kind: ramp``)."""
    return {"kind": "ramp", "mode": "scale", "times": [0.0, duration / 6, 5 * duration / 6],
            "values": [1.0, 1.0, 1.0 - STIFFNESS_DROP]}


def damping_drift(duration: float) -> dict:
    """(times, scale values) of the damper blow-off for a run of ``duration`` seconds (``kind: ramp``)."""
    return {"kind": "ramp", "mode": "scale", "times": [0.0, duration / 2, duration / 2 + duration / 100],
            "values": [1.0, 1.0, 1.0 - DAMPING_DROP]}


def drift_kind(v) -> str | None:
    """'stiffness' or 'damping' when a ``vehicle.variations`` entry is the mode I drift of that kind (by its
    parameter name), else None."""
    name = v.param if hasattr(v, "param") else v["param"]
    if "stiffness" in name and "tire" not in name:
        return "stiffness"
    if "damping" in name and "tire" not in name:
        return "damping"
    return None


def matches(v, duration: float) -> bool:
    """True if the variation entry is exactly the mode I drift of its kind for this run length."""
    kind = drift_kind(v)
    if kind is None:
        return False
    want = stiffness_drift(duration) if kind == "stiffness" else damping_drift(duration)
    get = (lambda k: getattr(v, k)) if hasattr(v, "param") else v.get
    return (get("kind") == want["kind"] and get("mode") == want["mode"]
            and all(abs(a - b) < 1e-9 for a, b in zip(get("times"), want["times"]))
            and len(get("times")) == 3
            and all(abs(a - b) < 1e-9 for a, b in zip(get("values"), want["values"])))
