"""Actuator mechanical power and energy per corner (and summed over corners)."""
import numpy as np
from scipy import integrate

from ..registry import METRICS
from ._util import peak
from .base import EnsembleView, Reductions, RunView, ensemble_version, peak_rows, stream_version


@METRICS.register("actuator_power")
def actuator_power(run: RunView) -> dict:
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
    out = {}
    t = run.col("t")
    tot = {"actuator_power_mean_abs": 0.0, "actuator_power_mean_pos": 0.0, "actuator_energy": 0.0}
    for s in run.suffixes:
        p = run.col(f"actuator_force{s}") * run.col(f"travel_rate{s}")
        vals = {
            "actuator_power_mean_abs": float(np.mean(np.abs(p))) if p.size else float("nan"),
            "actuator_power_mean_pos": float(np.mean(np.clip(p, 0.0, None))) if p.size else float("nan"),
            "actuator_energy": float(integrate.trapezoid(np.abs(p), t)) if p.size > 1 else 0.0,
        }
        for k, v in vals.items():
            out[f"{k}{s}"] = v
            tot[k] += v
        out[f"actuator_power_peak{s}"] = peak(p)
    if len(run.suffixes) > 1:
        out.update({f"{k}_total": v for k, v in tot.items()})
    return out


@ensemble_version(actuator_power, channels=("actuator_force{s}", "travel_rate{s}"))
def _actuator_power_many(ens: EnsembleView) -> dict:
    out = {}
    t = ens.t
    tot = {"actuator_power_mean_abs": 0.0, "actuator_power_mean_pos": 0.0, "actuator_energy": 0.0}
    for s in ens.suffixes:
        p = ens.col(f"actuator_force{s}") * ens.col(f"travel_rate{s}")
        n, m = p.shape
        vals = {
            "actuator_power_mean_abs": np.mean(np.abs(p), axis=1) if m else np.full(n, np.nan),
            "actuator_power_mean_pos": np.mean(np.clip(p, 0.0, None), axis=1) if m else np.full(n, np.nan),
            "actuator_energy": integrate.trapezoid(np.abs(p), t, axis=-1) if m > 1 else np.zeros(n),
        }
        for k, v in vals.items():
            out[f"{k}{s}"] = v
            tot[k] = tot[k] + v
        out[f"actuator_power_peak{s}"] = peak_rows(p)
    if len(ens.suffixes) > 1:
        out.update({f"{k}_total": v for k, v in tot.items()})
    return out


@stream_version(actuator_power)
class _ActuatorPowerStream:
    def __init__(self, meta: EnsembleView):
        self.meta, self.r = meta, Reductions()

    def update(self, ens: EnsembleView) -> None:
        self.r.start(ens)
        for s in ens.suffixes:
            p = ens.col(f"actuator_force{s}") * ens.col(f"travel_rate{s}")
            a = np.abs(p)
            self.r.sum(f"abs{s}", a)
            self.r.sum(f"pos{s}", np.clip(p, 0.0, None))
            self.r.trapezoid(f"e{s}", a, ens.t)
            self.r.max(f"pk{s}", a)

    def result(self) -> dict:
        n, out = self.meta.n_cars, {}
        tot = {"actuator_power_mean_abs": 0.0, "actuator_power_mean_pos": 0.0, "actuator_energy": 0.0}
        for s in self.meta.suffixes:
            vals = {
                "actuator_power_mean_abs": self.r.mean(f"abs{s}", n),
                "actuator_power_mean_pos": self.r.mean(f"pos{s}", n),
                "actuator_energy": self.r.v.get(f"e{s}", np.zeros(n)),
            }
            for k, v in vals.items():
                out[f"{k}{s}"] = v
                tot[k] = tot[k] + v
            out[f"actuator_power_peak{s}"] = self.r.get(f"pk{s}", n)
        if len(self.meta.suffixes) > 1:
            out.update({f"{k}_total": v for k, v in tot.items()})
        return out
