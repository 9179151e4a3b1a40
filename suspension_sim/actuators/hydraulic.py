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
``S = w3`` (see :func:`_kernel_advance`), so no iteration is needed and the square-root singularity at
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
from .base import Actuator
from ..compiled.numpy_order import sign
from ..kernels import optional


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


# ---------------------------------------------------------------------------------------------------------
# the law for one corner.
# p = [alpha, area, beta, gamma, P_s, tau, xlim, friction?, friction_max, friction_velocity, ctx.dt, n_sub,
#      max_substep, e_1 .. e_nsub]  with e_k = exp(-(k·h)/tau) at h = ctx.dt/n_sub, precomputed in
#      kernel_data (another dt than the physics step uses math.exp);
# st = [P_L, x_v, G, G set?, F, A·P_L, F_f]
_HP = 13  # index of e_1 in p


@numba.njit(cache=True)
def _kernel_force(cmd, s, v, t, dt, p, st):
    """The force of one corner: P_L = G − α·A·travel (the stiff oil spring exact, see the module docstring),
    F = A·P_L − F_f,max·tanh(travel rate/v_f)."""
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
    """The state of one corner over dt: on each of n_sub sub-steps the spool lag exactly (exponential toward
    the held command, clipped at the end stops), then one trapezoidal step of the pressure
    dP/dt = −β·P − α·A·v + γ·x_v·w3(P, x_v), x_v frozen at the sub-step end.  With a = 1 + hβ/2,
    σ = sgn(x_v1) and S = w3(P1) the implicit equation

        a·P1 − (h/2)·γ·x_v1·S = K := P0 + (h/2)·f0 − (h/2)·α·A·v,   P1 = σ·(P_s − S·|S|)
        =>  a·S·|S| + b·S − c = 0,  b = (h/2)·γ·|x_v1|,  c = a·P_s − σ·K

    is strictly increasing in S, so S = 2c / (b + sqrt(b² + 4a|c|)) (the stable root formula)."""
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
        # spool lag over (i + 1)·h from the step start
        if exact:
            e = p[_HP + i]
        else:
            e = math.exp(-((i + 1) * h) / tau)
        xv1 = u + (xv - u) * e
        if xv1 < -xlim:
            xv1 = -xlim
        elif xv1 > xlim:
            xv1 = xlim
        # the derivative at the sub-step start, w3 = sgn(D)·sqrt|D| (Lin & Kanellakopoulos Eq. 7)
        D = Ps - sign(xv0) * P
        f0 = -beta * P - ar + gamma * xv0 * (sign(D) * math.sqrt(abs(D)))
        # the trapezoidal step
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

    kernel_force = staticmethod(_kernel_force)
    kernel_advance = staticmethod(_kernel_advance)

    def kernel_data(self):
        """(p, st) of the kernels; layout in the comment above ``_kernel_force``."""
        p, ctx = self.p, self.ctx
        lim = optional(p.spool_limit)
        xlim = np.where(np.isnan(lim), np.inf, lim)  # none: no end stop
        n_sub = np.maximum(1, np.ceil(ctx.dt / np.asarray(p.max_substep, dtype=float) - 1e-9))  # per car
        h = ctx.dt / n_sub
        e = [np.exp(-((i + 1) * h) / p.spool_time_constant) for i in range(int(np.max(n_sub)))]
        kp = self.pack(p.alpha, p.area, p.beta, p.gamma, p.supply_pressure, p.spool_time_constant, xlim,
                       p.friction_max > 0, p.friction_max, p.friction_velocity, ctx.dt, n_sub, p.max_substep, *e)
        P0 = np.asarray(p.initial_pressure, dtype=float)
        return kp, self.pack(P0, 0.0, 0.0, 0.0, 0.0, p.area * P0, 0.0)

    def kernel_states(self):
        return {"load_pressure": 0, "spool_position": 1, "hydraulic_force": 5, "friction_force": 6,
                "force": 4}
