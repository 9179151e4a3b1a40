"""Ideal force actuator with the usual non-idealities: pure delay, first-order lag, rate limit and
saturation (applied in that order to the commanded force)."""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..free_parameters import FreeParameter
from ..registry import ACTUATORS
from ._common import kernel_pack, optional_array
from .base import Actuator


class IdealParams(Params):
    max_force: float | None = Field(None, gt=0, description="saturation |F| <= max_force (N); none = unlimited")
    rate_limit: float | None = Field(None, gt=0, description="|dF/dt| limit (N/s); none = unlimited")
    time_constant: float = Field(0.0, ge=0, description="first-order lag time constant (s); 0 = none")
    delay: float = Field(0.0, ge=0, description="pure delay (s), rounded to physics steps")


# kernel layout (one corner): p = [lag?, a, rate?, dmax, sat?, max_force, n_delay]; st = [F, head, line[0..n_delay]]
@numba.njit(cache=True)
def _kernel_force(cmd, s, v, t, dt, p, st):
    """``IdealActuator.force`` for one corner (same operations, same order)."""
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
        if d < -dmax:  # np.clip (NaN propagates)
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
    """``IdealActuator.advance`` (nothing to do: the state changes in ``force``)."""
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

    def reset(self):
        n, c = self.ctx.n_cars, self.ctx.n_corners
        self.F = np.zeros((n, c))
        self.n_delay = int(round(float(np.max(self.p.delay)) / self.ctx.dt))
        self._line = np.zeros((self.n_delay + 1, n, c))
        self._head = 0
        tau = np.asarray(self.p.time_constant, dtype=float)
        self.lag = bool(np.any(tau > 0))
        self._a = np.where(tau > 0, np.exp(-self.ctx.dt / np.maximum(tau, 1e-300)), 0.0)
        self.rate = self.p.rate_limit is not None
        self.sat = self.p.max_force is not None

    def force(self, command, travel, travel_rate, t):
        u = command
        if self.n_delay:
            self._line[self._head] = command
            self._head = (self._head + 1) % (self.n_delay + 1)
            u = self._line[self._head]
        if self.lag:
            u = self._a * self.F + (1 - self._a) * u
        if self.rate:
            dmax = self.p.rate_limit * self.ctx.dt
            u = self.F + np.clip(u - self.F, -dmax, dmax)
        if self.sat:
            u = np.clip(u, -self.p.max_force, self.p.max_force)
        self.F = np.broadcast_to(np.asarray(u, dtype=float), self.F.shape).copy()
        return self.F

    def advance(self, command, travel, travel_rate, t, dt):
        pass

    def states(self):
        return {"force": self.F}

    kernel_force = staticmethod(_kernel_force)
    kernel_advance = staticmethod(_kernel_advance)

    def kernel_data(self):
        """p = [lag?, a, rate?, dmax, sat?, max_force, n_delay] (the flags and the delay-line length are
        ensemble-wide, as in :meth:`force`); st = [F, head, delay line (n_delay + 1)]."""
        ctx, p = self.ctx, self.p
        dmax = optional_array(p.rate_limit, 0.0) * ctx.dt if self.rate else 0.0
        fmax = optional_array(p.max_force, 0.0) if self.sat else 0.0
        kp = kernel_pack(ctx, float(self.lag), self._a, float(self.rate), dmax, float(self.sat), fmax,
                         float(self.n_delay))
        line = [self._line[j] for j in range(self.n_delay + 1)]
        st = kernel_pack(ctx, self.F, float(self._head), *line)
        return kp, st

    def kernel_states(self):
        return {"force": 0}
