"""Electro-hydraulic actuator: four-way spool valve driving a double-acting cylinder (Merritt 1967; the
Alleyne–Hedrick quarter-car actuator used by Kim and by Lin & Kanellakopoulos).

States per corner: load pressure ``P_L`` (Pa; the hydraulic force is ``A·P_L``) and spool position ``x_v``
(m).  The command is the servo-valve input ``u`` (m of spool travel)::

    dP_L/dt = −β·P_L − α·A·(ẋ_s − ẋ_w) + γ·x_v·w3,   w3 = sgn(P_s − sgn(x_v)·P_L)·sqrt|P_s − sgn(x_v)·P_L|
    dx_v/dt = (u − x_v)/τ,                          |x_v| <= spool_limit (end stops)
    F      = A·P_L − F_f,                            F_f = F_f,max·tanh((ẋ_s − ẋ_w)/v_f)   (optional seal friction)

``ẋ_s − ẋ_w`` is the suspension travel rate (positive = extension) and ``F`` pushes the body up and the
wheel down.  Defaults are Lin & Kanellakopoulos (1996) Eq. (11): A = 3.35e-4 m², α = 4βe/Vt = 4.515e13 N/m⁵,
β = α·C_tp = 1 s⁻¹, γ = α·C_d·w·sqrt(1/ρ) = 1.545e9 N/(m^{5/2}·kg^{1/2}), P_s = 10 342 500 Pa (1500 psi),
τ = 1/30 s, spool limit ±1 cm.  Kim (1996) writes the same plant for the force F_a = A·P_L with
a1 = β, a2 = α·A = 15.125e9 and a3 = A·γ = 5.176e5 (his Table 1 entry for a1 is garbled: it repeats A_p;
a1 = β = 1 s⁻¹ is consistent with the other paper), a spool constant ε = 0.003 s and seal friction
|F_f,max| = 250 N.  The paper does not give a friction law; a tanh-smoothed Coulomb force with velocity
scale ``friction_velocity`` is our choice.

Integration (why results do not change when the physics step is halved).  The term −α·A·(ẋ_s − ẋ_w) is a
stiff hydraulic spring (α·A² ≈ 5e6 N/m, ~47 Hz against the wheel mass).  Integrating it with the travel
rate held over the physics step (the rate is only known at the start of the step) is explicit Euler on the
wheel/oil oscillator and grows unstable at the default step.  Instead the actuator keeps
``G = P_L + α·A·travel``, whose derivative −β·P_L + γ·x_v·w3 has no travel-rate term, and recovers
``P_L = G − α·A·travel`` from the *actual* travel at the start of every step (in :meth:`force`): the spring
part is then integrated exactly, whatever MuJoCo does between steps, and the coupling is the ordinary
position-dependent force of a semi-implicit step.  Over each step :meth:`advance` integrates the remaining
(mildly nonlinear) pressure dynamics on sub-steps of at most ``max_substep`` with the trapezoidal rule,
solved in closed form: with x_v frozen at the sub-step end, the implicit equation is a quadratic in
``S = w3`` (see :func:`_trapezoid_step`), so no iteration is needed and the square-root singularity at
|P_L| = P_s (where an explicit method would need tiny steps) is handled without special cases.  The spool
lag is integrated exactly (exponential toward the held command, clipped at the end stops).
"""
from __future__ import annotations

import math

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import ACTUATORS
from ._common import kernel_pack
from .base import Actuator
from ..compiled.numpy_order import sign


class HydraulicParams(Params):
    area: float = Field(3.35e-4, gt=0, description="piston area A (m²)")
    alpha: float = Field(4.515e13, gt=0, description="α = 4βe/Vt (N/m⁵)")
    beta: float = Field(1.0, ge=0, description="β = α·C_tp, leakage (1/s)")
    gamma: float = Field(1.545e9, gt=0, description="γ = α·C_d·w·sqrt(1/ρ) (N/(m^2.5·kg^0.5))")
    supply_pressure: float = Field(10342500.0, gt=0, description="P_s (Pa)")
    spool_time_constant: float = Field(1.0 / 30.0, gt=0, description="τ of the spool lag (s); Kim: 0.003")
    spool_limit: float | None = Field(0.01, gt=0, description="|x_v| end stop (m); none = unlimited")
    friction_max: float = Field(0.0, ge=0, description="seal friction |F_f,max| (N); Kim: 250")
    friction_velocity: float = Field(0.01, gt=0, description="tanh velocity scale of the friction (m/s)")
    initial_pressure: float = Field(0.0, description="P_L at t = 0 (Pa)")
    max_substep: float = Field(2.5e-4, gt=0, description="longest internal sub-step of the pressure integration (s)")


def _trapezoid_step(P0, f0, xv1, h, alpha_rate, p):
    """One trapezoidal step of dP/dt = −β·P − α·A·v + γ·x_v·w3(P, x_v) from P0 (derivative f0 at the start)
    to the end point, where x_v = xv1.  With a = 1 + hβ/2, σ = sgn(xv1) and S = w3(P1):

        a·P1 − (h/2)·γ·xv1·S = K := P0 + (h/2)·f0 − (h/2)·α·A·v,   P1 = σ·(P_s − S·|S|)
        =>  a·S·|S| + b·S − c = 0,  b = (h/2)·γ·|xv1|,  c = a·P_s − σ·K

    which is strictly increasing in S, so S = 2c / (b + sqrt(b² + 4a|c|)) (the stable root formula)."""
    a = 1.0 + 0.5 * h * p.beta
    K = P0 + 0.5 * h * f0 - 0.5 * h * alpha_rate
    sig = np.sign(xv1)
    b = 0.5 * h * p.gamma * np.abs(xv1)
    c = a * p.supply_pressure - sig * K
    S = 2.0 * c / (b + np.sqrt(b * b + 4.0 * a * np.abs(c)))
    P1 = np.where(sig != 0, sig * (p.supply_pressure - S * np.abs(S)), K / a)
    return P1


def w3(P, xv, Ps):
    """Valve flow factor sgn(P_s − sgn(x_v)·P_L)·sqrt|P_s − sgn(x_v)·P_L| (Lin & Kanellakopoulos Eq. 7)."""
    D = Ps - np.sign(xv) * P
    return np.sign(D) * np.sqrt(np.abs(D))


# ---------------------------------------------------------------------------------------------------------
# compiled kernels (see suspension_sim.compiled): the same operations as force()/advance() for one corner.
# p = [alpha, area, beta, gamma, P_s, tau, xlim, friction?, friction_max, friction_velocity, ctx.dt, n_sub,
#      min max_substep, e_1 .. e_nsub]  with e_k = exp(-(k·h)/tau) at h = ctx.dt/n_sub, evaluated by numpy in
#      kernel_data exactly as _spool does (so the kernel is bit-identical at the physics step; another dt falls
#      back to math.exp, within an ulp of numpy's exp);
# st = [P_L, x_v, G, G set?, F, A·P_L, F_f]
_HP = 13  # index of e_1 in p



@numba.njit(cache=True)
def _kernel_force(cmd, s, v, t, dt, p, st):
    """``HydraulicActuator.force`` for one corner."""
    if st[3] == 0.0:
        st[2] = st[0] + p[0] * p[1] * s
        st[3] = 1.0
    P = st[2] - p[0] * p[1] * s
    st[0] = P
    Fh = p[1] * P
    st[5] = Fh
    if p[7] != 0.0:
        st[6] = p[8] * math.tanh(v / p[9])
    F = Fh - st[6]
    st[4] = F
    return F


@numba.njit(cache=True)
def _kernel_advance(cmd, s, v, t, dt, p, st):
    """``HydraulicActuator.advance`` for one corner (spool lag, trapezoidal pressure sub-steps)."""
    alpha, area, beta, gamma, Ps, tau, xlim = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    u = cmd
    if st[3] == 0.0:
        st[2] = st[0] + alpha * area * s
        st[3] = 1.0
    exact = dt == p[10]
    if exact:
        n_sub = int(p[11])
    else:
        n_sub = max(1, int(math.ceil(dt / p[12] - 1e-9)))
    h = dt / n_sub
    ar = alpha * area * v
    P = st[2] - alpha * area * s
    xv = st[1]
    xv0 = xv
    for i in range(n_sub):
        # _spool(u, (i + 1)·h)
        if exact:
            e = p[_HP + i]
        else:
            e = math.exp(-((i + 1) * h) / tau)
        xv1 = u + (xv - u) * e
        if xv1 < -xlim:
            xv1 = -xlim
        elif xv1 > xlim:
            xv1 = xlim
        # _deriv(P, xv0, ar), w3(P, xv0, P_s)
        D = Ps - sign(xv0) * P
        f0 = -beta * P - ar + gamma * xv0 * (sign(D) * math.sqrt(abs(D)))
        # _trapezoid_step(P, f0, xv1, h, ar)
        a = 1.0 + 0.5 * h * beta
        K = P + 0.5 * h * f0 - 0.5 * h * ar
        sig = sign(xv1)
        b = 0.5 * h * gamma * abs(xv1)
        c = a * Ps - sig * K
        S = 2.0 * c / (b + math.sqrt(b * b + 4.0 * a * abs(c)))
        if sig != 0.0:
            P = sig * (Ps - S * abs(S))
        else:
            P = K / a
        xv0 = xv1
    st[1] = xv0
    travel_end = s + v * dt
    st[2] = P + alpha * area * travel_end
    st[0] = P
    st[5] = area * P


@ACTUATORS.register("hydraulic")
class HydraulicActuator(Actuator):
    """Four-way spool valve + double-acting cylinder (states load_pressure, spool_position); command = spool
    input u in m.  See the module docstring for the equations, parameter sources and integration scheme."""

    Params = HydraulicParams
    command_unit = "m"

    def reset(self):
        n, c = self.ctx.n_cars, self.ctx.n_corners
        p = self.p
        self.P = np.broadcast_to(np.asarray(p.initial_pressure, dtype=float), (n, c)).copy()
        self.xv = np.zeros((n, c))
        self.G = None  # P_L + α·A·travel, set at the first force() call (travel unknown before)
        self.F = np.zeros((n, c))
        self.Fh = np.zeros((n, c))
        self.Ff = np.zeros((n, c))
        lim = p.spool_limit  # stacked: array (n, 1); None (all cars) or a list mixing None and numbers
        if lim is None or isinstance(lim, list):
            lim = [np.inf if v is None else float(v) for v in (lim if isinstance(lim, list) else [None] * n)]
        lim = np.asarray(lim, dtype=float)
        lim = np.where(np.isnan(lim), np.inf, lim)  # stacking turns a None among numbers into NaN
        self.xlim = np.broadcast_to(lim.reshape(n, -1), (n, c)).copy()
        self.n_sub = max(1, int(math.ceil(self.ctx.dt / float(np.min(p.max_substep)) - 1e-9)))

    # ---------------------------------------------------------------------------------------------
    def _spool(self, u, s):
        p = self.p
        x = u + (self.xv - u) * np.exp(-s / p.spool_time_constant)
        return np.clip(x, -self.xlim, self.xlim)

    def _deriv(self, P, xv, alpha_rate):
        p = self.p
        return -p.beta * P - alpha_rate + p.gamma * xv * w3(P, xv, p.supply_pressure)

    def force(self, command, travel, travel_rate, t):
        p = self.p
        if self.G is None:
            self.G = self.P + p.alpha * p.area * travel
        self.P = self.G - p.alpha * p.area * travel
        self.Fh = p.area * self.P
        if np.any(p.friction_max > 0):
            self.Ff = p.friction_max * np.tanh(travel_rate / p.friction_velocity)
        self.F = self.Fh - self.Ff
        return self.F

    def advance(self, command, travel, travel_rate, t, dt):
        p = self.p
        u = np.asarray(command, dtype=float)
        if self.G is None:
            self.G = self.P + p.alpha * p.area * travel
        n_sub = self.n_sub if dt == self.ctx.dt else max(1, int(math.ceil(dt / float(np.min(p.max_substep)) - 1e-9)))
        h = dt / n_sub
        ar = p.alpha * p.area * travel_rate  # α·A·(ẋ_s − ẋ_w), held over the step
        P = self.G - p.alpha * p.area * travel
        xv0 = self.xv
        for i in range(n_sub):
            xv1 = self._spool(u, (i + 1) * h)
            f0 = self._deriv(P, xv0, ar)
            P = _trapezoid_step(P, f0, xv1, h, ar, p)
            xv0 = xv1
        self.xv = xv0
        travel_end = travel + travel_rate * dt
        self.G = P + p.alpha * p.area * travel_end
        self.P = P

    def states(self):
        return {"load_pressure": self.P, "spool_position": self.xv, "hydraulic_force": self.p.area * self.P,
                "friction_force": self.Ff, "force": self.F}

    kernel_force = staticmethod(_kernel_force)
    kernel_advance = staticmethod(_kernel_advance)

    def kernel_data(self):
        """(p, st) of the kernels; layout in the comment above ``_kernel_force``."""
        p, ctx = self.p, self.ctx
        h = ctx.dt / self.n_sub
        e = [np.exp(-((i + 1) * h) / p.spool_time_constant) for i in range(self.n_sub)]  # as in _spool
        kp = kernel_pack(ctx, p.alpha, p.area, p.beta, p.gamma, p.supply_pressure, p.spool_time_constant,
                         self.xlim, float(np.any(p.friction_max > 0)), p.friction_max, p.friction_velocity,
                         ctx.dt, float(self.n_sub), float(np.min(p.max_substep)), *e)
        G = np.zeros_like(self.P) if self.G is None else self.G
        st = kernel_pack(ctx, self.P, self.xv, G, float(self.G is not None), self.F, self.p.area * self.P,
                         self.Ff)
        return kp, st

    def kernel_states(self):
        return {"load_pressure": 0, "spool_position": 1, "hydraulic_force": 5, "friction_force": 6,
                "force": 4}
