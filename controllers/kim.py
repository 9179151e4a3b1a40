"""Kim (1996): nonlinear *indirect* adaptive force control of a hydraulic actuator, sky-hook outer loop.

Source: E.-S. Kim, *Nonlinear indirect adaptive control of a quarter car active suspension*
(``shared/seeds/000_bf32727a261a7c8a.txt``), Eqs. (5)–(33).  Plant: the Alleyne–Hedrick quarter car without
a passive damper and the hydraulic actuator of ``suspension_sim/actuators/hydraulic.py`` (Kim's
a1 = β, a2 = α·A, a3 = A·γ, spool constant ε = 0.003 s, seal friction 250 N).

Per control step, per corner (x = F_a, the actuator force):

- desired force (5): ``x_d = F_d = −C_sh·ẋ2 − B_s·(ẋ2 − ẋ1)``: sky-hook on the body velocity plus "a passive
  damping term" on the deflection rate.  The text prints ``+B_s·(ẋ2 − ẋ1)``; with F_a pushing the body up
  (Eq. 2) that term would be a *negative* damper (it feeds energy into the wheel-hop mode of this car, which
  has no shock absorber), so we use the dissipative sign.  Eq. (18) writes x_d = −C_sh·ẋ2; we use all of (5);
- outer loop (18): ``v = ẋ_d − k_d·x_e`` with ``x_e = x − x_d``, or (33) ``v = −k_d·x_e`` without ẋ_d
  (``use_fd_dot``).  ẋ_d = −C_sh·ẍ2 − B_s·(ẍ2 − ẍ1) comes from a body and a wheel accelerometer;
- slow control (17): ``u_s = (v − f̂)/ĝ`` with ``f̂ = θ̂1·x + θ̂2·A_p·(ẋ2 − ẋ1)``,
  ``ĝ = θ̂3·sqrt|P_s − sgn(X_V)·x/A_p|`` (kept above ``g_min_fraction``·a3·sqrt(P_s): the paper assumes ĝ
  lower bounded);
- fast/slow composite control (7): ``u = (1 + K_pf)·u_s − K_pf·X_V`` (spool position X_V measured);
- estimator (22)–(23): ``dx̂/dt = −α1·(x̂ − x) + θ̂ᵀY_r``, ``Y_r = [x, A_p(ẋ2 − ẋ1), sqrt|P_s − sgn(X_V)x/A_p|·u_s]``,
  estimation error ``p_e = x̂ − x``;
- adaptation (27): ``dθ̃/dt = Γ2·Y_r·p_e`` with θ̃ = θ − θ̂, i.e. ``dθ̂/dt = −Γ2·Y_r·p_e``, θ = [−a1, −a2, a3].

Sampled-data realisation.  The law is continuous-time; here it runs once per control step with the command
held.  The estimator and the adaptation law are integrated over each control interval after it ends; the
hydraulic-spring part θ2·A_p·(ẋ2 − ẋ1) exactly, as θ2·A_p·Δ(travel) from the deflection sensor (the rectangle
rule on it is off by (Tc/2)·a2·A_p·(ẍ2 − ẍ1), several hundred N at this plant's force rates of ~1e6 N/s), the
rest by the rectangle rule.  The cancellation of the same term in (17) is the weak point of any sampled
version: a command computed at the start of the interval and held lags the continuous law by Tc/2, which
leaves a force-rate error ≈ a2·A_p·(ẍ2 − ẍ1)·Tc/2 that the loop rejects only at the rate k_d.  At k_d = 10
(Fig. 2) that made the force error first order in the step (21.0, 17.0, 15.1, 14.2, 13.8 N at 0.1 … 0.00625
ms).  ``hold_midpoint`` (used by the scenarios) evaluates the deflection rate of f̂ at the middle of the hold
from the accelerometers; the known-parameter case is then converged at 0.1 ms (19.0, 18.9, 18.8 N) and both
realisations tend to the same limit (adaptive: 13.4 N).  What remains in that limit is the spool lag
ε/(1 + K_pf) that the reduced model (14) neglects.
``rate_prediction`` (not in the paper) predicts the deflection rate a further T ahead; the scenarios' variant
``rate_prediction`` uses T = ε/(1 + K_pf) for that spool lag.

Results: ``suspension-sim reproduce kim`` (scenarios/kim_fig2..5.yaml: the literal law adapting from a2 −20 %,
a3 +20 %, beside the known-parameter and non-adaptive cases); numbers and verdicts in
docs/reproductions/kim_1996.md.

Sensors (what a car with this actuator has; declare them in the scenario under these names):
the force x (``force_sensor``, default ``actuator_force``: a load cell on the rod, which reads A·P_L − F_f, so
seal friction enters the force loop as an unmodelled disturbance; the Kim scenarios use a differential
pressure transducer instead, an ``actuator_state`` sensor with ``state: hydraulic_force`` = A·P_L, which is the
x = F_a of Eq. (3)), ``travel`` and ``travel_rate`` (suspension deflection and its rate, LVDT),
``corner_body_vel`` (body velocity above the corner, integrated accelerometer), ``spool_position`` (type
``actuator_state`` with ``state: spool_position``, the servo valve's LVDT) and, with ``use_fd_dot`` or
``rate_prediction``, ``corner_body_acc`` and ``wheel_acc`` (body and wheel accelerometers).

Constants the paper does not give (chosen here, and stated in the scenario files): the fast-control gain
K_pf (20: ε/(1 + K_pf) = 0.14 ms with ε = 3 ms; the sampled spool loop u → X_V is stable for
K_pf < (1 + e^(−Tc/ε))/(1 − e^(−Tc/ε)), 59 at Tc = 0.1 ms, 12 at 0.5 ms), the adaptation gains Γ2 (given per
parameter, normalised: ``d(θ̂_i/θ_i0)/dt = −gain_i·(θ_i0·Y_i)·p_e``, θ_i0 the Table 1 value, gain in 1/N²;
with θ2·Y2 ~ 1e6 N/s the (p_e, θ̃) loop then has its slow pole near gain·(θ_i0·Y_i)²/α1), the initial
estimates (Table 1 by default: the paper's simulations give no initial error) and the ĝ floor.

The law is written once, as the numba function ``_kernel`` (one car): the compiled loop inlines it and the
base class runs it over the ensemble in the Python loop (tests/test_kernels_controllers.py checks it against
the equations above).
"""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from suspension_sim.compiled.numpy_order import sign

A1, A2, A3 = 1.0, 15.125e9, 5.176e5  # Kim Table 1 (a1 reconstructed = β of Lin & Kanellakopoulos)


class KimParams(Params):
    c_sky: float = Field(3000.0, ge=0, description="sky-hook damping C_sh (N·s/m)")
    b_s: float = Field(1000.0, ge=0, description="passive damping term B_s of the desired force (N·s/m)")
    k_d: float = Field(1000.0, gt=0, description="force-loop gain k_d (1/s); Kim: 10 and 1000")
    use_fd_dot: bool = Field(True, description="outer loop (18) with dF_d/dt (True) or (33) without it (False)")
    alpha1: float = Field(30.0, gt=0, description="estimator gain α1 (1/s)")
    k_pf: float = Field(20.0, ge=0, description="fast-control gain K_pf of Eq. (7) (chosen)")
    area: float = Field(3.35e-4, gt=0, description="A_p (m²), known")
    supply_pressure: float = Field(10342500.0, gt=0, description="P_s (Pa), known")
    a1: float = Field(A1, description="initial estimate of a1 (1/s)")
    a2: float = Field(A2, description="initial estimate of a2 (N/m⁵·m² = N/m³)")
    a3: float = Field(A3, description="initial estimate of a3")
    adaptive: bool = Field(True, description="update θ̂ by Eq. (27); False keeps the initial estimates")
    gain_a1: float = Field(1e-10, ge=0, description="normalised adaptation gain of θ1 = −a1 (1/N²)")
    gain_a2: float = Field(1e-10, ge=0, description="normalised adaptation gain of θ2 = −a2 (1/N²)")
    gain_a3: float = Field(1e-10, ge=0, description="normalised adaptation gain of θ3 = a3 (1/N²)")
    g_min_fraction: float = Field(0.05, gt=0, description="lower bound of ĝ as a fraction of a3·sqrt(P_s)")
    rate_prediction: float = Field(0.0, ge=0, description=(
        "not in the paper: predict the deflection rate this far ahead (s) in the cancelled term f̂, "
        "ẋ2 − ẋ1 + T·(ẍ2 − ẍ1), to offset the hold and spool lag of a sampled implementation (needs the "
        "accelerometers); 0 = Kim's law"))
    hold_midpoint: bool = Field(False, description=(
        "sampled-data realisation of the continuous law: evaluate the deflection rate of f̂ at the middle of the "
        "hold interval, ẋ2 − ẋ1 + (Tc/2)·(ẍ2 − ẍ1), instead of at its start (needs the accelerometers). The "
        "held command then matches the continuous law's mean over the interval to second order; without it "
        "the hold lags the cancellation by Tc/2 and the k_d = 10 force error is first order in Tc"))
    force_sensor: str = Field("actuator_force", description="name of the sensor giving the actuator force (N)")
    spool_sensor: str = Field("spool_position", description="name of the spool-position sensor (m)")


# parameter row
(_P_CSKY, _P_BS, _P_KD, _P_FD, _P_ALPHA1, _P_KPF, _P_AREA, _P_PS, _P_G1, _P_G2, _P_G3, _P_ADAPT, _P_GMIN, _P_RP,
 _P_TC, _P_OX, _P_OS, _P_OVREL, _P_OVB, _P_OXV, _P_OAB, _P_OAW) = range(22)
_NP = 22
# state row: [has_prev] then blocks of n_corners
_S_BLOCKS = ("x_hat", "s_prev", "Y3_prev", "F_d", "F_a", "force_error", "p_e", "u_s", "a1_hat", "a2_hat",
             "a3_hat")
_SB = {name: k for k, name in enumerate(_S_BLOCKS)}


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: desired force (5), outer loop (18)/(33), slow control (17), composite control (7);
    then the estimator (22)-(23) and the adaptation (27) over the interval that has just ended."""
    nc = u.shape[0]
    c_sky, b_s, k_d, area = p[_P_CSKY], p[_P_BS], p[_P_KD], p[_P_AREA]
    Tc = p[_P_TC]
    has_prev = st[0] != 0.0
    for c in range(nc):
        x = y[int(p[_P_OX]) + c]
        vrel = y[int(p[_P_OVREL]) + c]
        vb = y[int(p[_P_OVB]) + c]
        XV = y[int(p[_P_OXV]) + c]
        if not has_prev:
            st[1 + 0 * nc + c] = x  # x_hat starts at the measured force
        xd = -c_sky * vb - b_s * vrel  # (5), with the dissipative sign of the damping term (module docstring)
        xe = x - xd
        v = -k_d * xe  # (33)
        if p[_P_FD] != 0.0:  # (18): + dx_d/dt from the accelerometers
            ab = y[int(p[_P_OAB]) + c]
            aw = y[int(p[_P_OAW]) + c]
            v = v + (-c_sky * ab - b_s * (ab - aw))
        # feedback-linearising slow control (17) with the current estimates
        Y1 = x
        Y2 = area * vrel
        if p[_P_RP] > 0.0:  # deflection rate predicted T ahead (not in the paper)
            Y2 = area * (vrel + p[_P_RP] * (y[int(p[_P_OAB]) + c] - y[int(p[_P_OAW]) + c]))
        sq = np.sqrt(np.abs(p[_P_PS] - sign(XV) * x / area))
        th1 = -st[1 + 8 * nc + c]
        th2 = -st[1 + 9 * nc + c]
        th3 = st[1 + 10 * nc + c]
        f_hat = th1 * Y1 + th2 * Y2
        g = th3 * sq
        g_min = p[_P_GMIN]
        g_hat = g if (g >= g_min or g != g) else g_min  # ĝ floor (a NaN passes)
        us = (v - f_hat) / g_hat
        uc = (1.0 + p[_P_KPF]) * us - p[_P_KPF] * XV  # (7)
        # estimator (22)-(23) and adaptation law (27) over the control interval that has just ended: the
        # hydraulic-spring part θ2·A_p·(ẋ2 − ẋ1) exactly, as θ2·A_p·Δ(travel)/Tc from the deflection sensor; the
        # other terms by the rectangle rule with the previous step's values
        s_now = y[int(p[_P_OS]) + c]
        x_hat = st[1 + 0 * nc + c]
        if has_prev:
            x0 = st[1 + 4 * nc + c]  # F_a of the previous step
            s0 = st[1 + 1 * nc + c]
            Y3p = st[1 + 2 * nc + c]
            pe0 = st[1 + 6 * nc + c]
            Y1p = x0
            Y2i = area * (s_now - s0) / Tc  # mean A_p·(ẋ2 − ẋ1) over the interval
            xhat_dot = -p[_P_ALPHA1] * pe0 + th1 * Y1p + th2 * Y2i + th3 * Y3p
            if p[_P_ADAPT] != 0.0:  # dθ̂_i/dt = −gain_i·θ_i0·(θ_i0·Y_i)·p_e (normalised gains)
                sc = -A1
                th1 = th1 - Tc * p[_P_G1] * sc * (sc * Y1p) * pe0
                sc = -A2
                th2 = th2 - Tc * p[_P_G2] * sc * (sc * Y2i) * pe0
                sc = A3
                th3 = th3 - Tc * p[_P_G3] * sc * (sc * Y3p) * pe0
                st[1 + 8 * nc + c] = -th1
                st[1 + 9 * nc + c] = -th2
                st[1 + 10 * nc + c] = th3
            x_hat = x_hat + Tc * xhat_dot
            st[1 + 0 * nc + c] = x_hat
        pe = x_hat - x
        st[1 + 1 * nc + c] = s_now
        st[1 + 2 * nc + c] = sq * us
        st[1 + 3 * nc + c] = xd
        st[1 + 4 * nc + c] = x
        st[1 + 5 * nc + c] = xe
        st[1 + 6 * nc + c] = pe
        st[1 + 7 * nc + c] = us
        u[c] = uc
    st[0] = 1.0


@CONTROLLERS.register("kim")
class Kim(Controller):
    """Kim (1996): indirect adaptive force control (estimator + gradient law) of the hydraulic actuator,
    sky-hook desired force; command = spool input (m)."""

    Params = KimParams
    kernel = staticmethod(_kernel)

    @classmethod
    def required_sensors(cls, raw):
        req = [str(raw.get("force_sensor", "actuator_force")), "travel", "travel_rate", "corner_body_vel",
               raw.get("spool_sensor", "spool_position")]
        if (raw.get("use_fd_dot", True) or float(raw.get("rate_prediction", 0) or 0) > 0
                or raw.get("hold_midpoint", False)):
            req += ["corner_body_acc", "wheel_acc"]
        return req

    def _starts(self, name):
        """Per-car start of reading ``name`` (one name, or one per car) in the kernel's reading vector."""
        names = name if isinstance(name, list) else [name] * self.ctx.n_cars
        return [self.ctx.reading_start(nm) for nm in names]

    def kernel_data(self):
        n, nc, p, col = self.ctx.n_cars, self.ctx.n_corners, self.p, self.per_car

        P = np.zeros((n, _NP))
        P[:, _P_CSKY], P[:, _P_BS], P[:, _P_KD] = col(p.c_sky), col(p.b_s), col(p.k_d)
        P[:, _P_FD] = col(p.use_fd_dot)  # flags may differ across an ensemble
        P[:, _P_ALPHA1], P[:, _P_KPF] = col(p.alpha1), col(p.k_pf)
        P[:, _P_AREA], P[:, _P_PS] = col(p.area), col(p.supply_pressure)
        P[:, _P_G1], P[:, _P_G2], P[:, _P_G3] = col(p.gain_a1), col(p.gain_a2), col(p.gain_a3)
        P[:, _P_ADAPT] = col(p.adaptive)
        P[:, _P_GMIN] = col(p.g_min_fraction * A3 * np.sqrt(p.supply_pressure))
        P[:, _P_TC] = self.ctx.control_dt
        P[:, _P_RP] = col(p.rate_prediction) + 0.5 * self.ctx.control_dt * col(p.hold_midpoint)
        P[:, _P_OX] = self._starts(p.force_sensor)
        P[:, _P_OS] = self._starts("travel")
        P[:, _P_OVREL] = self._starts("travel_rate")
        P[:, _P_OVB] = self._starts("corner_body_vel")
        P[:, _P_OXV] = self._starts(p.spool_sensor)
        accelerometers = np.any(P[:, _P_FD] != 0) or np.any(P[:, _P_RP] > 0)
        P[:, _P_OAB] = self._starts("corner_body_acc") if accelerometers else -1.0
        P[:, _P_OAW] = self._starts("wheel_acc") if accelerometers else -1.0
        S = np.zeros((n, 1 + len(_S_BLOCKS) * nc))
        for name, v in (("a1_hat", p.a1), ("a2_hat", p.a2), ("a3_hat", p.a3)):  # θ̂(0): Table 1 by default
            k = _SB[name]
            S[:, 1 + k * nc:1 + (k + 1) * nc] = np.asarray(v, dtype=float).reshape(-1, 1)
        return P, S

    def kernel_signals(self):
        nc = self.ctx.n_corners
        return {name: (1 + _SB[name] * nc, 1 + (_SB[name] + 1) * nc)
                for name in ("F_d", "F_a", "force_error", "p_e", "u_s", "a1_hat", "a2_hat", "a3_hat")}
