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

import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import ACTUATORS
from .base import Actuator


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
