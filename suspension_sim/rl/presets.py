"""The scenarios behind ``suspension_sim/QuarterCar-v0``, ``HalfCar-v0`` and ``FullCar-v0``.

Each is an ordinary scenario (a dict in the scenario format): an ISO 8608 class C road at 20 m/s, an ideal
force actuator per corner (±3 kN, 5 ms lag), sensors with a little noise, 200 Hz control, 5 s episodes.  The
sensor noise levels are chosen (a MEMS accelerometer's noise density over the band, an LVDT's resolution),
not from a paper.  Override anything with ``gymnasium.make(..., overrides=["road.params.road_class=D"])``.
"""
from __future__ import annotations

import copy

_COMMON = {
    "road": {"type": "iso8608", "params": {"road_class": "C"}, "speed": 20.0},
    "actuator": {"type": "ideal", "params": {"max_force": 3000.0, "time_constant": 0.005}},
    "controller": {"type": "passive"},
    "sim": {"duration": 5.0, "dt": 0.0005, "control_dt": 0.005, "log_dt": 0.005, "seed": 0},
    "outputs": {"timeseries": False, "plots": False},
}

_CORNER_SENSORS = [
    {"name": "corner_body_acc", "type": "corner_body_acc", "noise_std": 0.05},  # m/s²
    {"name": "corner_body_vel", "type": "corner_body_vel", "noise_std": 0.002},  # m/s
    {"name": "travel", "type": "travel", "noise_std": 0.0002},  # m
    {"name": "travel_rate", "type": "travel_rate", "noise_std": 0.002},  # m/s
]

PRESETS = {
    "quarter_car": {
        "name": "rl_quarter_car",
        "description": "Quarter car (Alleyne–Hedrick) on an ISO 8608 class C road at 20 m/s, ideal actuator ±3 kN.",
        "vehicle": {"model": "quarter_car"},
        "sensors": _CORNER_SENSORS,
        **_COMMON,
    },
    "half_car": {
        "name": "rl_half_car",
        "description": "Half car (thesis Ch. 7) on an ISO 8608 class C road at 20 m/s, ideal actuators ±3 kN.",
        "vehicle": {"model": "half_car"},
        "sensors": _CORNER_SENSORS,
        **_COMMON,
    },
    "full_car": {
        "name": "rl_full_car",
        "description": "Full car (mid-size sedan) on an ISO 8608 class C road at 20 m/s (independent left/right "
                       "tracks), ideal actuators ±3 kN.",
        "vehicle": {"model": "full_car"},
        "sensors": _CORNER_SENSORS,
        **_COMMON,
    },
}
PRESETS["full_car"]["road"] = {**_COMMON["road"], "tracks": "independent"}

ENV_IDS = {"QuarterCar-v0": "quarter_car", "HalfCar-v0": "half_car", "FullCar-v0": "full_car"}


def preset(model: str) -> dict:
    """A copy of the preset scenario dict for ``model`` (quarter_car, half_car, full_car)."""
    return copy.deepcopy(PRESETS[model])
