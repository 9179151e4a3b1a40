"""Names of the log channels (one place for the loops, the log and the outputs).

A body joint's position, velocity and acceleration channels: heave is ``body_z``/``body_vel``/``body_acc``,
pitch ``pitch``/``pitch_rate``/``pitch_acc``, roll ``roll``/``roll_rate``/``roll_acc``; any other joint ``j``
gives ``j``/``j_vel``/``j_acc``.  The full list of channels is in :mod:`suspension_sim.results`.
"""
from __future__ import annotations

BODY_NAMES = {
    "body_z": ("body_z", "body_vel", "body_acc"),
    "pitch": ("pitch", "pitch_rate", "pitch_acc"),
    "roll": ("roll", "roll_rate", "roll_acc"),
}


def body_channels(joint: str) -> tuple[str, str, str]:
    """(position, velocity, acceleration) channel names of a body joint."""
    return BODY_NAMES.get(joint, (joint, f"{joint}_vel", f"{joint}_acc"))
