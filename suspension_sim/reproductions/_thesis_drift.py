"""The thesis's Parametric variations mode I drifts (Sec. 2.3.1, Figs. 2.7–2.8), defined once.

The thesis shows, as figures without numbers, "a gradual change of air spring stiffness with temperature and
blow-off of the shock absorber valves" and uses them "for the purpose of testing the adaptive capabilities of
the controller".  Their size and timing are not recoverable from the text, so they are ours, stated here and
nowhere else (the scenario files carry them as ``vehicle.variations`` entries with ``mode: scale``, and
``tests/test_thesis_drift.py`` checks every thesis scenario that uses them against this module):

- stiffness: every spring −20 %, linearly from T/6 to 5T/6 of a run of length T (60 s: from 10 s to 50 s);
- damping: every linear damper −50 % at T/2 (60 s: at 30 s), a valve blow-off (a step).

(The numbers are those thesis_ch3_adaptation.yaml chose for Ch. 3, kept for every chapter.)

A velocity-squared (orifice) damper is a plant *effect*; the damping drift reaches it through a variation of the
effect's coefficient (``effects.quadratic_damping.c_v``, the same ``scale`` step), so every damper of a chapter
drifts, linear or not (Ch. 4's rig, the Ch. 6 primary, Ch. 7's half car).
"""
from __future__ import annotations

STIFFNESS_DROP = 0.20
DAMPING_DROP = 0.50
# plant effects that are dampers, and the coefficient the damping drift scales
DAMPER_EFFECTS = {"quadratic_damping": "c_v"}


def stiffness_drift(duration: float) -> dict:
    """(times, scale values) of the spring drift for a run of ``duration`` seconds (``kind: ramp``)."""
    return {"kind": "ramp", "mode": "scale", "times": [0.0, duration / 6, 5 * duration / 6],
            "values": [1.0, 1.0, 1.0 - STIFFNESS_DROP]}


def damping_drift(duration: float) -> dict:
    """(times, scale values) of the damper blow-off for a run of ``duration`` seconds (``kind: step``)."""
    return {"kind": "step", "mode": "scale", "times": [duration / 2], "values": [1.0 - DAMPING_DROP]}


def drift_kind(v) -> str | None:
    """'stiffness' or 'damping' when a ``vehicle.variations`` entry has the form of the mode I drift of that
    kind (a ``scale`` ``ramp`` of a spring, a ``scale`` ``step`` of a damper after t = 0), else None (e.g. Ch. 5's
    own stiffness step)."""
    get = (lambda k: getattr(v, k)) if hasattr(v, "param") else v.get
    name = get("param")
    if get("mode") != "scale":
        return None
    if name.startswith("effects."):  # effects.<label>.<param>: only an effect damper's coefficient drifts
        label, _, pname = name[len("effects."):].rpartition(".")
        if DAMPER_EFFECTS.get(label.split("#")[0]) != pname:
            return None
        name = "damping"
    if "tire" in name:
        return None
    if "stiffness" in name and get("kind") == "ramp":
        return "stiffness"
    if "damping" in name and get("kind") == "step" and min(get("times"), default=0.0) > 0.0:
        return "damping"  # (a step at t = 0 is a plant that differs from the design, not a drift)
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
            and len(get("times")) == len(want["times"]) and len(get("values")) == len(want["values"])
            and all(abs(a - b) < 1e-9 for a, b in zip(get("values"), want["values"])))
