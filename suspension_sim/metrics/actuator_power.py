"""Actuator mechanical power and energy per corner (and summed over corners)."""
import numpy as np

from ..registry import METRICS
from .base import Accumulator, metric

_SUMMED = ("actuator_power_mean_abs", "actuator_power_mean_pos", "actuator_energy")


@METRICS.register("actuator_power")
@metric
class ActuatorPower(Accumulator):
    """Actuator mechanical power P = F·(travel rate): mean |P|, mean positive P (W) and energy ∫|P|dt (J).

    With the sign conventions (F > 0 pushes the body up and the wheel down, travel > 0 = extension),
    P = F·(ż_body − ż_wheel) is the power the actuator puts into the suspension: P > 0 it drives the motion,
    P < 0 it absorbs energy (acts as a damper).  Keys per corner:

    - ``actuator_power_mean_abs{s}`` = mean |P|, the average power flow through the actuator;
    - ``actuator_power_mean_pos{s}`` = mean max(P, 0), what an actuator that cannot regenerate must supply;
    - ``actuator_power_peak{s}`` = max |P|;
    - ``actuator_energy{s}`` = ∫|P| dt (trapezoid rule over the log), J.

    These are mechanical quantities at the actuator, not electrical or hydraulic input power (losses are the
    actuator model's business).  Multi-corner models also get ``..._total`` sums over corners.
    """

    channels = ("actuator_force{s}", "travel_rate{s}")

    def update(self, chunk) -> None:
        self.r.start(chunk)
        for s in chunk.suffixes:
            p = chunk.col(f"actuator_force{s}") * chunk.col(f"travel_rate{s}")
            a = np.abs(p)
            self.r.sum(f"abs{s}", a)
            self.r.sum(f"pos{s}", np.clip(p, 0.0, None))
            self.r.trapezoid(f"e{s}", a, chunk.t)
            self.r.max(f"pk{s}", a)

    def result(self) -> dict:
        out, tot = {}, dict.fromkeys(_SUMMED, 0.0)
        for s in self.meta.suffixes:
            vals = dict(zip(_SUMMED, (self.r.mean(f"abs{s}"), self.r.mean(f"pos{s}"), self.r.get(f"e{s}", 0.0))))
            for k, v in vals.items():
                out[f"{k}{s}"] = v
                tot[k] = tot[k] + v
            out[f"actuator_power_peak{s}"] = self.r.get(f"pk{s}")
        if len(self.meta.suffixes) > 1:
            out.update({f"{k}_total": v for k, v in tot.items()})
        return out
