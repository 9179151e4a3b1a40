"""Ideal force actuator with the usual non-idealities: pure delay, first-order lag, rate limit and
saturation (applied in that order to the commanded force)."""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..kernels import optional
from ..free_parameters import FreeParameter
from ..registry import ACTUATORS
from .base import Actuator


class IdealParams(Params):
    max_force: float | None = Field(None, gt=0, description="saturation |F| <= max_force (N); none = unlimited")
    rate_limit: float | None = Field(None, gt=0, description="|dF/dt| limit (N/s); none = unlimited")
    time_constant: float = Field(0.0, ge=0, description="first-order lag time constant (s); 0 = none")
    delay: float = Field(0.0, ge=0, description="pure delay (s), rounded to physics steps")


# kernel layout (one corner): p = [lag?, a, rate?, dmax, sat?, max_force, n_delay]; st = [F, head, line[0..n_delay]]
@numba.njit(cache=True)
def _kernel_force(cmd, s, v, t, dt, p, st):
    """The force of one corner: the command through the delay line, the lag F ← a·F + (1 − a)·u, the rate
    limit |ΔF| <= dmax per step and the saturation |F| <= max_force."""
    u = cmd
    nd = int(p[6])
    if nd:
        head = int(st[1])
        st[2 + head] = cmd
        head = (head + 1) % (nd + 1)
        st[1] = head
        u = st[2 + head]
    F = st[0]
    if p[0] != 0.0:
        a = p[1]
        u = a * F + (1 - a) * u
    if p[2] != 0.0:
        dmax = p[3]
        d = u - F
        if d < -dmax:  # NaN propagates
            d = -dmax
        elif d > dmax:
            d = dmax
        u = F + d
    if p[4] != 0.0:
        fm = p[5]
        if u < -fm:
            u = -fm
        elif u > fm:
            u = fm
    st[0] = u
    return u


@numba.njit(cache=True)
def _kernel_advance(cmd, s, v, t, dt, p, st):
    """Nothing to do: the state changes in ``_kernel_force``."""
    return


@ACTUATORS.register("ideal")
class IdealActuator(Actuator):
    """Force actuator: delay -> first-order lag -> rate limit -> saturation. Command = force demand (N).

    With no delay, lag, rate limit or saturation the force equals the command.  The lag is the exact
    zero-order-hold discretisation of dF/dt = (u − F)/τ over one physics step."""

    Params = IdealParams
    command_unit = "N"
    # what `suspension-sim diagnose` may fit between a measured force command and the force (one candidate
    # each; the delay is fitted as a continuous shift of the measured input, see diagnose/engine.py)
    free_parameters = {
        "time_constant": FreeParameter("1", init=0.005, lo=1e-5, hi=1.0, starts=(0.003, 0.02), candidate="actuator_lag"),
        "delay": FreeParameter("1", init=0.005, lo=0.0, hi=0.5, starts=(0.002, 0.015), candidate="actuator_delay",
                               target="input.delay"),
    }
    signatures = {
        "actuator_lag": "residual coherent with the force input above 1/(2πτ); high-frequency force attenuated, "
                        "−45° at the corner",
        "actuator_delay": "residual largest where the force command changes fast; phase lag growing linearly with "
                          "frequency (−360°·f·d)",
    }

    kernel_force = staticmethod(_kernel_force)
    kernel_advance = staticmethod(_kernel_advance)

    def kernel_data(self):
        """p = [lag?, a, rate?, dmax, sat?, max_force, n_delay] per car; st = [F, head, delay line (n_delay + 1
        slots; the longest of the ensemble)]."""
        ctx, p = self.ctx, self.p
        delay = np.rint(np.asarray(p.delay, dtype=float) / ctx.dt)
        tau = np.asarray(p.time_constant, dtype=float)
        a = np.where(tau > 0, np.exp(-ctx.dt / np.maximum(tau, 1e-300)), 0.0)  # exact ZOH lag over one step
        rate, fmax = optional(p.rate_limit), optional(p.max_force)  # NaN: none (the flag is off)
        kp = self.pack(tau > 0, a, ~np.isnan(rate), rate * ctx.dt, ~np.isnan(fmax), fmax, delay)
        return kp, self.pack(*([0.0] * (int(np.max(delay)) + 3)))  # F, head, the delay line
