"""What a divergence message says when MuJoCo met a NaN/Inf: the non-finite forces and the state.

When MuJoCo meets a NaN or Inf in ``ctrl``/``qacc``/... it resets the data and goes on, so the plant state
at the check is the reset state; what is left to show is the step's forces (the actuator force, the effect
forces, the controller's command) and which array MuJoCo complained about.  :func:`nonfinite_state` gathers
the non-finite entries of those (at most a handful), so the message is never an empty state list.
"""
from __future__ import annotations

import numpy as np


def nonfinite_state(sim, what: str, car: int | None = None) -> dict:
    """{name: value} of the non-finite forces of the last step (car ``car`` or every car), plus the MuJoCo
    array that held the bad value."""
    out: dict = {}
    names = ("actuator_force", "effect_force", "tire_effect_force")
    forces = getattr(sim, "last_forces", ()) or ()
    sfx = list(getattr(sim.plant, "suffixes", [])) or [""]
    for name, f in zip(names, forces):
        a = np.asarray(f, dtype=float)
        if a.ndim != 2:
            continue
        rows = [car] if car is not None and car < a.shape[0] else range(a.shape[0])
        for i in rows:
            for c in range(a.shape[1]):
                if not np.isfinite(a[i, c]):
                    key = f"{name}{sfx[c] if c < len(sfx) else c}" + (f"[car {i}]" if a.shape[0] > 1 and car is None else "")
                    out[key] = float(a[i, c])
                    if len(out) >= 6:
                        break
    if what:
        out["mujoco_bad_value_in"] = what
    return out
