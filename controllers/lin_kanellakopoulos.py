"""Lin & Kanellakopoulos (1996): adaptive backstepping with tuning functions and a nonlinear travel filter.

Source: J.-S. Lin, I. Kanellakopoulos, *Adaptive nonlinear control in active suspensions*, IFAC World Congress
1996 (``shared/seeds/002_90485fcc6c630944.txt``).  The text was extracted from a web page and every Greek
letter became the same replacement glyph; the symbols below are reconstructed from the structure of the
equations and checked by re-deriving the paper's closed-loop error system (16)–(20) (see
``tests/test_lin.py``).  Where the reconstruction is a choice it says so.

Plant (6)–(7), x1 = x_s, x2 = ẋ_s, x3 = x_w, x4 = ẋ_w, x5 = P_L, x6 = x_v, η = x1 − x3 (suspension travel):

    ẋ2 = −[K_a·η + C_a·η̇ − A·x5]/M_b
    ẋ4 = [K_a·η + C_a·η̇ − A·x5 − K_t·(x3 − r)]/M_us
    ẋ5 = −β·x5 − θ·η̇ + γ·x6·w3,   θ = α·A (the only parameter estimated),  w3 as in Eq. (7)
    ẋ6 = (u − x6)/τ

(``suspension_sim/actuators/hydraulic.py`` simulates it; the passive spring/damper K_a, C_a act in parallel.)

Nonlinear filter (9)–(10): dx̄3/dt = −(ε + ε1·φ(η))·(x̄3 − x3), φ = ((|η| − m1)/m2)⁴ beyond |η| > m1, 0 inside.
Regulated output (8): z1 = x1 − x̄3.  The gains (25) give one filter constant "= 1.5"; the issue text reads
"filter constants 1.5", so ε = ε1 = 1.5 (a choice).

Backstepping (our complete derivation; D(·) is the time derivative along the *known* part of the vector
field: r is unknown and left out of ẋ4, θ is replaced by θ̂ in ẋ5, and d/dt φ⁽ᵏ⁾ = φ⁽ᵏ⁺¹⁾·η̇):

    α1 = −c1·z1 − (ε + ε1·φ)·η,                                     z2 = x2 − α1
    α2 = (ρ·M_b/A)·[−c2·z2 − z1 + (K_a·η + C_a·η̇)/M_b + D(α1)],     z3 = ρ·x5 − α2
    α3 = [−c3·z3 − b3·h3²·z3 − (A/(ρ·M_b))·z2 + ρ·β·x5 + ρ·θ̂·η̇ + D(α2)]/(ρ·γ),   z4 = x6·w3 − α3
    ω3 = −η̇,  ω4 = −(ω3/ρ)·[|x6|/(2|w3|) + ∂α3/∂x5],  τ3 = ω3·z3,  τ4 = τ3 + ω4·z4
    dθ̂/dt = (Γ/ρ)·τ4                                                           (12)
    α4 = x6·w3/τ − c4·z4 − ρ·γ·z3 − b4·h4²·z4 + |x6|·(−β·x5 − θ̂·η̇ + γ·x6·w3)/(2|w3|)
         + D(α3) + (∂α3/∂θ̂)·dθ̂/dt
    u  = τ·α4/w3                                                                (15)

with the r-coefficients R3 = −(∂α2/∂x4)·K_t/M_us = d3 + n3·h3 and R4 = −(∂α3/∂x4)·K_t/M_us = d4 + n4·h4, where
n3 = n4 = ρ·M_b·K_t/(A·M_us), d3 = n3·(C_a/M_b − ε), h3 = −ε1·φ − ε1·φ'·η (the paper's (17)–(18), which our
derivation reproduces symbolically) and d4 = (c1 + c2 + c3)·d3/(ρ·γ) + K_t·(K_a − m_t·C_a² + ε·m_t·C_a·M_b)/(A·M_us·γ),
m_t = 1/M_b + 1/M_us (the paper's (19); its extracted text lost the factor 1/γ of the second term, which the
units require); h4 = (R4 − d4)/n4 carries the θ̂- and φ-dependent rest (the paper's (20), too garbled to
compare term by term).  The closed loop is then (16)

    ż1 = −c1·z1 − (ε + ε1·φ)·z1 + z2
    ż2 = −c2·z2 − z1 + (A/(ρ·M_b))·z3
    ż3 = −c3·z3 − (A/(ρ·M_b))·z2 + ρ·γ·z4 + R3·r − b3·h3²·z3 + ρ·θ̃·ω3
    ż4 = −c4·z4 − ρ·γ·z3 + R4·r − b4·h4²·z4 + ρ·θ̃·ω4,      θ̃ = θ − θ̂

and V = ½·Σz_i² + (ρ·θ̃)²/(2Γ) has the derivative (22).  The coupling constant ρ·γ of z3 and z4 is printed as one
glyph in the paper; ρ·γ is what the definitions z3 = ρ·x5 − α2, z4 = x6·w3 − α3 give.  The paper's Fig. 4
plots ρ·θ̂ (1350–1550 for θ = αA = 1.5125e10 N/m³ and ρ = 1e-7); the signal ``theta_hat`` is that quantity.

The derivatives D(·), ∂/∂x4, ∂/∂x5, ∂/∂θ̂ are taken by sympy once per process (a few seconds) and compiled with
``lambdify``.  The w3 guard of Section 5 (|w3| < 1 -> ±1 in the denominators of (12) and (15)) is applied.

Sampled-data realisation: the law runs every control step with the spool command held; the filter error
x̄3 − x3 is advanced exactly for a wheel velocity varying linearly over the step, θ̂ by forward Euler.  With the default control step of
0.1 ms (c_i = 200 1/s) this is close to the paper's continuous-time law.

Sensors (Lin & Kanellakopoulos assume the full state): ``travel`` (LVDT), ``wheel_pos`` (absolute wheel
position, the x3 of the filter and of K_t·x3; on a car this is a double-integrated accelerometer, drift
ignored), ``corner_body_vel`` and ``wheel_vel`` (integrated accelerometers), ``load_pressure`` and
``spool_position`` (``actuator_state`` sensors with ``state: load_pressure`` / ``spool_position``).

Results (scenarios/lin_fig4/5.yaml; docs/issue3_results.md): travel stays inside ±8 cm; the adaptive run's
body-acceleration deviation from the known-parameter run is 0.45 (Fig. 4) and 0.36 (Fig. 5) of the
non-adaptive one's; ρθ̂ rises 1361 -> ~1530 (Fig. 4) and 1512.5 -> ~1680 ≈ 1.1·1512.5 (Fig. 5, the value that
restores θ̂/γ̂ = θ/γ).  Along a trajectory, (16) and (22) hold to the sampling error (tests/test_lin.py).

Variants (Figs. 4–5): ``adaptive: false`` keeps θ̂ at its initial value (non-adaptive); "known parameters" is
a scenario whose nominal values equal the plant's.  θ̂(0) = (nominal α)·(nominal A), as in the paper.
"""
from __future__ import annotations

import functools

import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller

_STATE = ("x1", "x2", "x3", "x4", "x5", "xb", "P0", "P1", "P2", "P3", "th", "S", "Q")
_PARAM = ("Mb", "Mus", "Ka", "Ca", "Kt", "A", "beta", "gam", "rho", "c1", "c2", "c3", "c4", "b3", "b4", "eps",
          "eps1", "Gam")
_OUT = ("z1", "z2", "z3", "z4", "alpha3", "omega4", "tau4", "thdot", "h3", "h4", "R3", "R4", "d3", "d4",
        "alpha4_rest")


@functools.lru_cache(maxsize=1)
def derivation():
    """Symbolic derivation (sympy).  Returns a dict: ``sym`` (the symbols by name), ``expr`` (sympy
    expressions by output name, plus ``alpha1``, ``alpha2``, ``n3``), and the compiled functions ``f_math``
    (python floats) and ``f_numpy`` (arrays), both taking the arguments ``_STATE + _PARAM`` and returning the
    outputs ``_OUT``.  S = x6·w3 (valve flow factor), Q = |x6|/(2|w3|) (guarded)."""
    import sympy as sp

    sy = {n: sp.Symbol(n, real=True) for n in _STATE}
    sy.update({n: sp.Symbol(n, positive=True) for n in _PARAM})
    x1, x2, x3, x4, x5, xb = (sy[k] for k in ("x1", "x2", "x3", "x4", "x5", "xb"))
    P0, P1, P2, P3, th, S, Q = (sy[k] for k in ("P0", "P1", "P2", "P3", "th", "S", "Q"))
    Mb, Mus, Ka, Ca, Kt, A, beta, gam, rho = (sy[k] for k in ("Mb", "Mus", "Ka", "Ca", "Kt", "A", "beta", "gam", "rho"))
    c1, c2, c3, c4, b3, b4, eps, eps1, Gam = (sy[k] for k in ("c1", "c2", "c3", "c4", "b3", "b4", "eps", "eps1", "Gam"))

    eta, etad = x1 - x3, x2 - x4
    known = {  # the known part of the vector field (r and θ̃ left out)
        x1: x2,
        x2: -(Ka * eta + Ca * etad - A * x5) / Mb,
        x3: x4,
        x4: (Ka * eta + Ca * etad - A * x5 - Kt * x3) / Mus,
        x5: -beta * x5 - th * etad + gam * S,
        xb: -(eps + eps1 * P0) * (xb - x3),
        P0: P1 * etad, P1: P2 * etad, P2: P3 * etad,
    }

    def D(e):
        return sum(sp.diff(e, v) * fv for v, fv in known.items())

    z1 = x1 - xb
    alpha1 = -c1 * z1 - (eps + eps1 * P0) * eta
    z2 = x2 - alpha1
    alpha2 = (rho * Mb / A) * (-c2 * z2 - z1 + (Ka * eta + Ca * etad) / Mb + D(alpha1))
    z3 = rho * x5 - alpha2
    h3 = -eps1 * P0 - eps1 * P1 * eta
    n3 = rho * Mb * Kt / (A * Mus)
    d3 = n3 * (Ca / Mb - eps)
    R3 = -sp.diff(alpha2, x4) * Kt / Mus
    alpha3 = (-c3 * z3 - b3 * h3 ** 2 * z3 - (A / (rho * Mb)) * z2 + rho * beta * x5 + rho * th * etad
              + D(alpha2)) / (rho * gam)
    z4 = S - alpha3
    omega3 = -etad
    omega4 = -(omega3 / rho) * (Q + sp.diff(alpha3, x5))
    tau4 = omega3 * z3 + omega4 * z4
    thdot = (Gam / rho) * tau4
    R4 = -sp.diff(alpha3, x4) * Kt / Mus
    mt = 1 / Mb + 1 / Mus
    d4 = (c1 + c2 + c3) * d3 / (rho * gam) + Kt * (Ka - mt * Ca ** 2 + eps * mt * Ca * Mb) / (A * Mus * gam)
    h4 = (R4 - d4) / n3
    x5dot_hat = -beta * x5 - th * etad + gam * S
    alpha4_rest = (-c4 * z4 - rho * gam * z3 - b4 * h4 ** 2 * z4 + Q * x5dot_hat + D(alpha3)
                   + sp.diff(alpha3, th) * thdot)
    expr = dict(z1=z1, z2=z2, z3=z3, z4=z4, alpha1=alpha1, alpha2=alpha2, alpha3=alpha3, omega4=omega4,
                tau4=tau4, thdot=thdot, h3=h3, h4=h4, R3=R3, R4=R4, d3=d3, d4=d4, n3=n3, alpha4_rest=alpha4_rest)
    args = [sy[n] for n in _STATE + _PARAM]
    outs = [expr[k] for k in _OUT]
    return {
        "sym": sy, "expr": expr,
        "f_math": sp.lambdify(args, outs, "math", cse=True),
        "f_numpy": sp.lambdify(args, outs, "numpy", cse=True),
    }


def phi_derivatives(eta, m1, m2):
    """φ(η) of Eq. (10) and its first three derivatives: with d = η − m1 (η > m1), η + m1 (η < −m1), 0
    otherwise: φ = (d/m2)⁴, φ' = 4d³/m2⁴, φ'' = 12d²/m2⁴, φ''' = 24d/m2⁴."""
    d = np.where(eta > m1, eta - m1, np.where(eta < -m1, eta + m1, 0.0))
    k = 1.0 / m2 ** 4
    return d ** 4 * k, 4 * d ** 3 * k, 12 * d ** 2 * k, 24 * d * k


class LinKanellakopoulosParams(Params):
    # nominal plant values used by the controller ("estimates", Table 1 / Eq. 11)
    sprung_mass: float = Field(290.0, gt=0, description="M_b (kg)")
    unsprung_mass: float = Field(59.0, gt=0, description="M_us (kg)")
    spring_stiffness: float = Field(16812.0, gt=0, description="K_a (N/m)")
    damping: float = Field(1000.0, ge=0, description="C_a (N·s/m)")
    tire_stiffness: float = Field(190000.0, gt=0, description="K_t (N/m)")
    area: float = Field(3.35e-4, gt=0, description="A (m²)")
    alpha: float = Field(4.515e13, gt=0, description="α (N/m⁵); θ̂(0) = α·A")
    beta: float = Field(1.0, ge=0, description="β (1/s)")
    gamma: float = Field(1.545e9, gt=0, description="γ")
    spool_time_constant: float = Field(1.0 / 30.0, gt=0, description="τ (s)")
    supply_pressure: float = Field(10342500.0, gt=0, description="P_s (Pa)")
    # design constants, Eq. (25)
    rho: float = Field(1e-7, gt=0, description="rescaling of x5 (ρ)")
    c1: float = Field(200.0, gt=0)
    c2: float = Field(200.0, gt=0)
    c3: float = Field(200.0, gt=0)
    c4: float = Field(200.0, gt=0)
    b3: float = Field(0.01, ge=0, description="nonlinear damping of the road term in step 3")
    b4: float = Field(0.01, ge=0, description="nonlinear damping of the road term in step 4")
    eps: float = Field(1.5, gt=0, description="filter constant ε (1/s)")
    eps1: float = Field(1.5, ge=0, description="filter constant ε1 (1/s), reconstructed = ε")
    m1: float = Field(0.055, ge=0, description="filter threshold m1 (m)")
    m2: float = Field(0.005, gt=0, description="filter scale m2 (m)")
    adaptation_gain: float = Field(40.0, ge=0, description="Γ of Eq. (12)")
    adaptive: bool = Field(True, description="update θ̂ (False: non-adaptive, θ̂ = α·A fixed)")
    w3_guard: float = Field(1.0, gt=0, description="|w3| below this is replaced by ±w3_guard in denominators")


def _flag(v, n):
    return np.asarray(v if isinstance(v, (list, tuple)) else [v] * n, dtype=float).reshape(n, 1)


@CONTROLLERS.register("lin_kanellakopoulos")
class LinKanellakopoulos(Controller):
    """Lin & Kanellakopoulos (1996): adaptive backstepping (tuning functions, θ = α·A) with the nonlinear
    travel filter; command = spool input (m).  See the module docstring."""

    Params = LinKanellakopoulosParams
    requires = ("travel", "wheel_pos", "corner_body_vel", "wheel_vel", "load_pressure", "spool_position")

    def reset(self):
        n, c = self.ctx.n_cars, self.ctx.n_corners
        p = self.p
        self.sh = (n, c)
        self.e = None  # filter error x̄3 − x3
        self._prev = None
        self.th = np.broadcast_to(np.asarray(p.alpha, float) * np.asarray(p.area, float), self.sh).copy()
        self.adaptive = _flag(p.adaptive, n)
        self.sig = {k: np.zeros(self.sh) for k in _OUT}
        self.sig.update(phi=np.zeros(self.sh), omega3=np.zeros(self.sh), u=np.zeros(self.sh))
        names = {"Mb": "sprung_mass", "Mus": "unsprung_mass", "Ka": "spring_stiffness", "Ca": "damping",
                 "Kt": "tire_stiffness", "A": "area", "beta": "beta", "gam": "gamma", "rho": "rho", "c1": "c1",
                 "c2": "c2", "c3": "c3", "c4": "c4", "b3": "b3", "b4": "b4", "eps": "eps", "eps1": "eps1",
                 "Gam": "adaptation_gain"}
        self.par = [np.broadcast_to(np.asarray(getattr(p, names[k]), float), self.sh) for k in _PARAM]
        self.par_el = [[float(a.flat[i]) for a in self.par] for i in range(n * c)]  # per element (math path)
        self.fn = derivation()

    def _get(self, y, name):
        return y[name] if name in y else y[f"state.{name}"]

    def step(self, t, y):
        p = self.p
        Tc = self.ctx.control_dt
        travel = self._get(y, "travel")
        x3 = self._get(y, "wheel_pos")
        x1 = travel + x3
        x2 = self._get(y, "corner_body_vel")
        x4 = self._get(y, "wheel_vel")
        x5 = self._get(y, "load_pressure")
        x6 = self._get(y, "spool_position")
        if self.e is None:
            self.e = np.zeros(self.sh)
        elif self._prev is not None:
            # filter error e = x̄3 − x3 over the interval that just ended: de/dt = −λ·e − x4 with λ held and
            # x4 the mean of its end values (trapezoid; holding x4 would be off by (Tc/2)·ẋ4 per step)
            lam, x4p = self._prev
            a = np.exp(-lam * Tc)
            self.e = self.e * a - 0.5 * (x4 + x4p) * (1.0 - a) / lam
        xb = x3 + self.e
        eta = x1 - x3
        P0, P1, P2, P3 = phi_derivatives(eta, p.m1, p.m2)
        D = p.supply_pressure - np.sign(x6) * x5
        w3 = np.sign(D) * np.sqrt(np.abs(D))
        g = p.w3_guard
        w3g = np.where(np.abs(w3) < g, np.where(w3 >= 0, g, -g), w3)
        S = x6 * w3
        Q = np.abs(x6) / (2.0 * np.abs(w3g))
        args = [x1, x2, x3, x4, x5, xb, P0, P1, P2, P3, self.th, S, Q]
        out = self._evaluate(args)
        tau = p.spool_time_constant
        alpha4 = x6 * w3 / tau + out["alpha4_rest"]
        u = tau * alpha4 / w3g

        # advance the controller states over the control step
        self._prev = (p.eps + p.eps1 * P0, x4)
        th_old = self.th
        self.th = self.th + self.adaptive * Tc * out["thdot"]

        out.update(phi=P0, omega3=-(x2 - x4), u=u)
        out["theta_hat"] = p.rho * th_old
        self.sig = out
        return u

    def _evaluate(self, args):
        n_el = self.sh[0] * self.sh[1]
        if n_el <= 8:
            cols = [np.asarray(a, float).reshape(-1) for a in args]  # all (n_cars, n_corners)
            f = self.fn["f_math"]
            res = np.array([f(*[float(c[i]) for c in cols], *self.par_el[i]) for i in range(n_el)])
            return {k: res[:, j].reshape(self.sh) for j, k in enumerate(_OUT)}
        res = self.fn["f_numpy"](*args, *self.par)
        return {k: np.broadcast_to(np.asarray(v, float), self.sh) for k, v in zip(_OUT, res)}

    def signals(self):
        s = self.sig
        keys = ("z1", "z2", "z3", "z4", "theta_hat", "omega3", "omega4", "h3", "h4", "R3", "R4", "d3", "d4",
                "phi", "u")
        return {k: s[k] for k in keys if k in s}
