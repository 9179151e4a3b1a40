"""Thesis Ch. 5: stochastic optimal control (LQG type) of the SDOF suspension on the Hac random road.

Plant (nominal, linear, Eq. 5.9): M* ẍ + C*(ẋ − ẇ) + K*(x − w) = F with M* = 250 kg, K* = 5000 N/m,
C* = 250 N·s/m.  Road: the 3rd-order Hac shaping filter Ẇ = M_d W + D_d ξ, w = W1
(:func:`suspension_sim.roads.hac.hac_shaping_filter` at the scenario speed).  Augmented state
X = [x, ẋ, W1, W2, W3] (ẇ = W2 + χ1 ξ; the white-noise part of ẇ is a noise input, not a state).

Cost (Eq. 5.10): PI = E[ẍ² + ρ1 (x − w)² + ρ2 F²].  With ẍ = C_a X + D_a F this is an LQR problem with a
cross term: Q = C_aᵀC_a + ρ1 e_rᵀe_r, N = C_aᵀD_a, R = D_a² + ρ2, solved by
``scipy.linalg.solve_continuous_are(A, B, Q, R, s=N)``; F = −K X with K = R⁻¹(BᵀP + Nᵀ).

Estimation (the "G" of LQG): x and ẋ are measured (``body_pos``, ``body_vel``); the road states come from
a steady-state discrete Kalman filter of the shaping filter (exact Van Loan discretisation at the control
step) that measures the road height w (``road`` sensor; measurement noise ``road_noise``).  The road is
uncontrollable and stable, so the separation principle holds: the LQR gain is the certainty-equivalent
optimum.

ρ1, ρ2 are not given by the thesis; the scenario files choose them.  The fixed-gain controller holds
no static level: a load change shifts the equilibrium by ΔM·g/(K + K_x) — with soft, comfort-oriented
weights the gain on x is negative (K_x < 0 cancels part of the spring), so that shift is large, and a
stiffness loss that makes K(t) + K_x < 0 makes the closed loop unstable: the thesis's "SOC goes unstable"
under time-varying stiffness.

Rescheduled variant (thesis: "recomputing the gains every 5–10 s with perfect knowledge"):
``update_period`` > 0 together with ``schedule`` — the *true* parameter history, given to the controller
explicitly (it is not measured) as a list of {time, mass, stiffness, damping} entries (each holds from
its time on).  Every ``update_period`` seconds the gains are recomputed for the parameters in force.
This is an oracle, as in the thesis; it is said in the scenario file.

Signals: ``gain.k`` (K), ``w_est.k`` (estimated road states), ``ref_*`` are not produced (no reference
model); ``pi_acc`` (ẍ predicted by the model).

The law is the numba kernel ``_kernel`` for one car (the base Controller broadcasts it over an ensemble,
the compiled loop inlines it), with the rescheduled gains precomputed at ``kernel_data`` (``_gain`` for
every schedule entry); tests/test_kernels_thesis.py checks it against the equations above.
"""
from __future__ import annotations

from typing import Optional

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.linalg import expm, solve_continuous_are, solve_discrete_are

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from .thesis_common import KernelLayout, k_dot, shared_value, stamped_cache


class ScheduleEntry(BaseModel):
    model_config = ConfigDict(extra="forbid")
    time: float
    mass: float = Field(..., gt=0)
    stiffness: float = Field(..., ge=0)
    damping: float = Field(..., ge=0)


class SOCParams(Params):
    mass: float = Field(250.0, gt=0, description="design M* (kg)")
    stiffness: float = Field(5000.0, ge=0, description="design K* (N/m)")
    damping: float = Field(250.0, ge=0, description="design C* (N·s/m)")
    rho1: float = Field(10.0, ge=0, description="weight ρ1 on (x − w)² (1/s⁴)")
    rho2: float = Field(1e-7, gt=0, description="weight ρ2 on F² (1/kg²)")
    surface: str = Field("dirt", description="Hac road of the design model (asphalt or dirt)")
    speed: float = Field(20.0, gt=0, description="m/s, speed of the design road model")
    road_noise: float = Field(1e-4, gt=0, description="std of the road-height measurement in the Kalman filter (m)")
    update_period: float = Field(0.0, ge=0, description="s between gain recomputations (0 = fixed gains)")
    schedule: Optional[list[ScheduleEntry]] = Field(None, description="true parameter history for the rescheduled variant")


def lqr_gain(M, K, C, Md, rho1, rho2):
    """(A, B, gain) of the Ch. 5 problem for plant parameters M, K, C and road matrix Md."""
    A = np.zeros((5, 5))
    A[0, 1] = 1.0
    A[1] = [-K / M, -C / M, K / M, C / M, 0.0]
    A[2:, 2:] = Md
    B = np.zeros((5, 1))
    B[1, 0] = 1.0 / M
    Ca = A[1:2].copy()
    Da = 1.0 / M
    er = np.array([[1.0, 0.0, -1.0, 0.0, 0.0]])
    Q = Ca.T @ Ca + rho1 * er.T @ er
    N = Ca.T * Da
    R = np.array([[Da * Da + rho2]])
    P = solve_continuous_are(A, B, Q, R, s=N)
    return A, B, np.linalg.solve(R, B.T @ P + N.T)


# ---- the law: one control step for one car (suspension_sim.compiled) ---------------------------------------
# p: sensor offsets x, ẋ, w; update period; n schedule entries; L (3); Φ (3 × 3); the nominal gain (5); the
# schedule times (n) and their gains (n × 5), computed by _gain at kernel_data.  st: gain (5), w_est (3),
# W (3), next update time, X (5).
_P_PER, _P_NS, _P_L, _P_PHI, _P_G0, _P_SCH = 3, 4, 5, 8, 17, 22
_ST_G, _ST_WF, _ST_W, _ST_NEXT, _ST_X = 0, 5, 8, 11, 12


@stamped_cache
@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """Gains of the schedule entry in force (at update instants), Kalman measurement update of the road
    states Wf = W + L (w − W1), F = −K [x, ẋ, Wf], prediction W ← Φ Wf (summed in order)."""
    if t + 1e-9 >= st[_ST_NEXT]:
        ns = int(p[_P_NS])
        src = _P_G0
        for e in range(ns):
            if t >= p[_P_SCH + e]:
                src = _P_SCH + ns + 5 * e
        for k in range(5):
            st[_ST_G + k] = p[src + k]
        st[_ST_NEXT] += p[_P_PER]
    x = y[int(p[0])]
    xd = y[int(p[1])]
    w = y[int(p[2])]
    innov = w - st[_ST_W]
    for j in range(3):
        st[_ST_WF + j] = st[_ST_W + j] + innov * p[_P_L + j]
    st[_ST_X] = x
    st[_ST_X + 1] = xd
    for j in range(3):
        st[_ST_X + 2 + j] = st[_ST_WF + j]
    u[0] = -k_dot(st, _ST_G, st, _ST_X, 5)
    for i in range(3):
        acc = 0.0
        for j in range(3):
            acc += st[_ST_WF + j] * p[_P_PHI + 3 * i + j]
        st[_ST_W + i] = acc


@CONTROLLERS.register("thesis_soc_lqg")
class SOCLQG(Controller):
    """Thesis Ch. 5 stochastic optimal control: LQR with the Hac shaping-filter states (cross-term CARE) + Kalman road estimate."""

    Params = SOCParams
    requires = ("body_pos", "body_vel", "road")
    kernel = staticmethod(_kernel)

    def reset(self):
        from suspension_sim.roads.hac import hac_shaping_filter

        super().reset()
        p, h = self.p, self.ctx.control_dt
        Md, Dd, Cw = hac_shaping_filter(p.surface, shared_value(p.speed))
        self.Md = Md
        # steady-state Kalman filter of the road model (exact discretisation, unit-intensity noise)
        nx = 3
        F = np.zeros((2 * nx, 2 * nx))
        F[:nx, :nx] = -Md
        F[:nx, nx:] = Dd @ Dd.T
        F[nx:, nx:] = Md.T
        E = expm(F * h)
        Phi = E[nx:, nx:].T
        Qd = Phi @ E[:nx, nx:]
        Qd = 0.5 * (Qd + Qd.T)
        Rv = np.array([[shared_value(p.road_noise) ** 2]])
        Pp = solve_discrete_are(Phi.T, Cw.T, Qd, Rv)
        self.Lk = Pp @ Cw.T @ np.linalg.inv(Cw @ Pp @ Cw.T + Rv)  # measurement update gain
        self.Phi, self.Cw = Phi, Cw
        self.next_update = shared_value(p.update_period) if shared_value(p.update_period) > 0 else np.inf

    def _gain(self, M, K, C):
        return lqr_gain(M, K, C, self.Md, shared_value(self.p.rho1), shared_value(self.p.rho2))[2][0]

    def _true_params(self, t):
        cur = (shared_value(self.p.mass), shared_value(self.p.stiffness), shared_value(self.p.damping))
        for e in self.p.schedule or []:
            if t >= e.time:
                cur = (e.mass, e.stiffness, e.damping)
        return cur

    def kernel_data(self):
        n, p = self.ctx.n_cars, self.p
        lay = KernelLayout(n)
        sched = list(p.schedule or [])
        lay.p([float(self.ctx.sensor_slice(nm)[0]) for nm in ("body_pos", "body_vel", "road")]
              + [shared_value(p.update_period), len(sched)])
        assert lay.p(self.Lk[:, 0]) == _P_L and lay.p(self.Phi) == _P_PHI
        gain0 = self._gain(*self._true_params(-np.inf))
        lay.p(gain0)
        lay.p([e.time for e in sched])
        lay.p(np.array([self._gain(e.mass, e.stiffness, e.damping) for e in sched]).reshape(-1))
        # gain, w_est, W (the predicted road state), the next update time, scratch X
        lay.st(np.concatenate([gain0, np.zeros(6), [float(self.next_update)], np.zeros(5)]))
        return lay.arrays()

    def kernel_signals(self):
        return {"gain": (_ST_G, _ST_G + 5), "w_est": (_ST_WF, _ST_WF + 3)}
