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
Regulated output (8): z1 = x1 − x̄3.  The gains (25) print one *unsubscripted* filter constant, "ε = 1.5"
(the extraction keeps subscripts elsewhere: "c 1", "m 2", "ε 1" in (9)); ε1 is not printed.  ε = 1.5 as
printed; ε1 = 0.01 1/s is reconstructed from the paper's figures: the figures identify only ε1/m2⁴
(ε1·φ = (ε1/m2⁴)·(|η| − m1)⁴), and with the printed m1 = 0.055, m2 = 0.005 every curve of Figs. 2–5 stays
inside the paper's axes for ε1 ≈ 0.005–0.012 (travel inside ±8 cm needs ε1 ≥ 0.005, Fig. 2's 12 m/s² axis
ε1 ≤ 0.012).  The earlier reading ε1 = ε = 1.5 (256× stiffer) gives a 5 ms, 57 m/s² spike when the
travel passes m1 that no figure shows (docs/reproductions/lin_kanellakopoulos_1996.md, item ``harshness``).

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

Results (scenarios/lin_fig4/5.yaml; docs/reproductions/lin_kanellakopoulos_1996.md): travel stays inside ±8 cm; the adaptive run's
body-acceleration deviation from the known-parameter run is 0.46 (Fig. 4) and 0.53 (Fig. 5) of the
non-adaptive one's; ρθ̂ rises 1361 -> ~1494 at 3 s (Fig. 4) and 1512.5 -> ~1653, toward 1.1·1512.5 (Fig. 5,
the value that restores θ̂/γ̂ = θ/γ).  Along a trajectory, (16) and (22) hold to the sampling error (tests/test_lin.py).

Variants (Figs. 4–5): ``adaptive: false`` keeps θ̂ at its initial value (non-adaptive); "known parameters" is
a scenario whose nominal values equal the plant's.  θ̂(0) = (nominal α)·(nominal A), as in the paper.

The law is written once, as the numba function ``_kernel`` (one car): the compiled loop inlines it and the
base class runs it over the ensemble in the Python loop.  The derivation's lambdified code is copied into
this file as a numba function (``kernel_source()``; a test checks that the copy is current, ``python -m
suspension_sim.controllers.lin_kanellakopoulos`` rewrites it), so sympy runs only in the tests.  Rounding: powers
by the C library's pow, as sympy's ``math`` printer writes them (squares as v·v for ensembles of more than 8
corners), and the filter's exp(−ε·Tc) precomputed by numpy: results are those of the numpy implementation
this kernel replaced.
"""
from __future__ import annotations

import functools
import math
import re
from suspension_sim.compiled.numpy_order import sign

import numba
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


def kernel_source() -> str:
    """Numba source of the derivation's ``f_math`` (the block between the GENERATED markers below; a test
    checks that it is up to date, ``python -m suspension_sim.controllers.lin_kanellakopoulos`` rewrites it): the
    lambdified Python code with each power ``v**k`` replaced by ``_pw(v, k, mode)``: mode 0 evaluates ``v**k``
    by the C library's pow (as ``f_math`` does; for k = 2 not always v·v), mode 1 squares by v·v (as
    ``f_numpy`` does)."""
    import inspect

    src = inspect.getsource(derivation()["f_math"])
    src = src.replace("def _lambdifygenerated(", "def _lin_eval(two, three, mode, ")
    src = re.sub(r"\b(\w+)\*\*([23])\b", lambda m: f"_pw({m.group(1)}, {'two' if m.group(2) == '2' else 'three'}, mode)", src)
    if "**" in src or "math." in src or "numpy" in src:
        raise AssertionError("lin_kanellakopoulos.kernel_source: unexpected construct in the lambdified code")
    lines = src.rstrip().splitlines()
    assert lines[-1].lstrip().startswith("return [") and lines[-1].endswith("]")
    lines[-1] = lines[-1].replace("return [", "return (", 1)[:-1] + ")"
    return "@numba.njit(cache=True)\n" + "\n".join(lines) + "\n"


@numba.njit(cache=True)
def _pw(v, k, mode):
    """v**k: mode 0 the C library's pow (as f_math), mode 1 v·v for k = 2 (as f_numpy) and pow otherwise; k is
    passed at run time so that the compiler cannot turn pow(v, 2.0) into v·v."""
    if mode == 1 and k == 2.0:
        return v * v
    return math.pow(v, k)


# --- GENERATED by kernel_source(), do not edit ---
@numba.njit(cache=True)
def _lin_eval(two, three, mode, x1, x2, x3, x4, x5, xb, P0, P1, P2, P3, th, S, Q, Mb, Mus, Ka, Ca, Kt, A, beta, gam, rho, c1, c2, c3, c4, b3, b4, eps, eps1, Gam):
    x0 = -xb
    x6 = x0 + x1
    x7 = x1 - x3
    x8 = P0*eps1
    x9 = eps + x8
    x10 = c1*x6 + x2 + x7*x9
    x11 = rho*x5
    x12 = c1 + x9
    x13 = x2 - x4
    x14 = P1*eps1
    x15 = x14*x7
    x16 = -x0 - x3
    x17 = -x9
    x18 = c1*x17
    x19 = x16*x18
    x20 = 1/Mb
    x21 = Ca*x13
    x22 = Ka*x7
    x23 = x21 + x22
    x24 = 1/A
    x25 = Mb*rho
    x26 = x24*x25
    x27 = x11 - x26*(-c2*x10 - x1 - x12*x2 - x13*x15 + x19 + x20*x23 + x4*x9 + xb)
    x28 = rho*th
    x29 = P2*_pw(x13, two, mode)
    x30 = eps1*x7
    x31 = x26*x30
    x32 = 1/rho
    x33 = A*x20*x32
    x34 = Ka*x20
    x35 = x13*x14
    x36 = -c2*x12 + x34 - x35 - 1
    x37 = x26*x36
    x38 = c1*c2 + x18 + 1
    x39 = x26*x38
    x40 = x17*x39
    x41 = eps1*x2
    x42 = c1*eps1
    x43 = c2*eps1
    x44 = eps1*x4 - x16*x42 - x41 - x43*x7
    x45 = x26*x44
    x46 = P1*x45
    x47 = -c2*x17 - x18 - x34 + x35
    x48 = x26*x47
    x49 = A*x5
    x50 = -Kt*x3 + x21 + x22 - x49
    x51 = 1/Mus
    x52 = Ca*x20
    x53 = x15 - x52
    x54 = x53 + x9
    x55 = x51*x54
    x56 = x26*x55
    x57 = -x23 + x49
    x58 = -c2 - x12 - x53
    x59 = rho*x24*x58
    x60 = -x15 - x8
    x61 = _pw(x60, two, mode)
    x62 = b3*x61
    x63 = 1/gam
    x64 = x32*x63
    x65 = x64*(beta*x11 - c3*x27 - x10*x33 + x13*x28 + x13*x46 + x16*x40 + x2*x37 - x27*x62 - x29*x31 + x4*x48 + x50*x56 + x57*x59)
    x66 = S - x65
    x67 = -x13
    x68 = c3*rho
    x69 = rho*x62
    x70 = x64*(beta*rho + rho*x58 - x25*x55 - x68 - x69)
    x71 = x32*x67*(Q + x70)
    x72 = x27*x67 - x66*x71
    x73 = Gam*x72
    x74 = Kt*x51
    x75 = P1*x26
    x76 = x41*x75
    x77 = eps1*x4
    x78 = x75*x77
    x79 = x26*x35
    x80 = 2*x2 - 2*x4
    x81 = P2*x31
    x82 = Mb*x24
    x83 = x68*x82
    x84 = Ca*x56
    x85 = Ca*x59
    x86 = x69*x82
    x87 = x64*(-x28 - x46 + x48 + x54*x83 + x54*x86 + x76 - x78 + x79 + x80*x81 - x84 + x85)
    x88 = x74*x87
    x89 = -eps + x52
    x90 = x24*x63*x74
    x91 = x20 + x51
    x92 = Mb*x89*x90*(c1 + c2 + c3) + x90*(-_pw(Ca, two, mode)*x91 + Ca*Mb*eps*x91 + Ka)
    x93 = -x88 - x92
    x94 = S*gam - beta*x5 - th*x13
    x95 = eps1*x24
    x96 = Mb*x7*x95
    x97 = x13*x75
    x98 = x50*x51
    x99 = Mb*x59
    x100 = x26*x41
    x101 = x13*x96
    x102 = rho*x57
    x103 = x102*x95
    x104 = 2*b3*x27*x60
    x105 = x13*x64
    x106 = x42 + x43
    x107 = eps1*x26
    x108 = Ka*x59 + x102*x14*x24 - x104*x14 + x107*x29 - x14*x26*x98
    return (x6, x10, x27, x66, x65, -x71, x72, x32*x73, x60, Mus*x33*x93/Kt, -Kt*x56, -x88, x26*x74*x89, x92, -_pw(A, two, mode)*_pw(Mus, two, mode)*b4*x66*_pw(x93, two, mode)/(_pw(Kt, two, mode)*_pw(Mb, two, mode)*_pw(rho, two, mode)) + P1*x105*(Mb*b3*rho*x24*x44*x61 + Mb*c3*rho*x24*x44 + Mb*eps1*rho*x24*x50*x51 + Mb*rho*x106*x24*x4 + 2*b3*eps1*x27*x60 - c2*x100 - eps1*x16*x39 - x103 - x107*x19 - x30*x33) + P2*x105*(eps1*x104*x7 - x100*x13 - x101*x68 - x101*x69 - x103*x7 + x13*x26*x77 + x13*x45 + x31*x98) - P3*_pw(x13, three, mode)*x63*x96 + Q*x94 - c4*x66 - gam*rho*x27 + x105*x73 + x16*x17*x64*(c1*x33 + x38*x83 + x38*x86 + x40 - x42*x97) + x2*x64*(Ka*Mb*rho*x24*x51*x54 + Mb*b3*rho*x24*x36*x61 + Mb*c3*rho*x24*x36 - x108 - x12*x33 - x43*x97) + x20*x57*x64*(c3*x99 + x28 - x33 + x37 + x46 + x62*x99 - x76 + x78 - x79 - x80*x81 + x84 - x85) + x4*x64*(P1*x106*x13*x26 + x108 - x17*x33 - x40 + x47*x83 + x47*x86 + x56*(-Ka - Kt)) + x70*x94 + x87*x98)
# --- END GENERATED ---


# the law ---------------------------------------------------------------------------------------------------
(_P_OTRAV, _P_OWPOS, _P_OVB, _P_OVW, _P_OPL, _P_OXV, _P_M1, _P_K4, _P_PS, _P_G, _P_TAU, _P_EPS, _P_EPS1, _P_TC,
 _P_ADAPT, _P_A0, _P_MODE, _P_TWO, _P_THREE, _P_FOUR) = range(20)
_NPH = 20  # then the 18 plant/design values of _PARAM
_SIG = ("z1", "z2", "z3", "z4", "theta_hat", "omega3", "omega4", "h3", "h4", "R3", "R4", "d3", "d4", "phi", "u")
_ST = ("e", "lam", "x4p", "th") + _SIG  # blocks of n_corners after [started]



@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: the filter error e = x̄3 − x3 advanced over the interval that just ended (de/dt =
    −λ·e − x4 with λ held and x4 the mean of its end values; holding x4 would be off by (Tc/2)·ẋ4 per step),
    φ(η) of Eq. (10) and its derivatives, w3 with the guard of Section 5, the derivation (``_lin_eval``), the
    command (15), and θ̂ by forward Euler of (12)."""
    nc = u.shape[0]
    started = st[0] != 0.0
    Tc = p[_P_TC]
    mode = int(p[_P_MODE])
    two, three, four = p[_P_TWO], p[_P_THREE], p[_P_FOUR]
    q = _NPH
    for c in range(nc):
        travel = y[int(p[_P_OTRAV]) + c]
        x3 = y[int(p[_P_OWPOS]) + c]
        x1 = travel + x3
        x2 = y[int(p[_P_OVB]) + c]
        x4 = y[int(p[_P_OVW]) + c]
        x5 = y[int(p[_P_OPL]) + c]
        x6 = y[int(p[_P_OXV]) + c]
        e = st[1 + c]
        if started:
            lam = st[1 + nc + c]
            x4p = st[1 + 2 * nc + c]
            if lam == p[_P_EPS]:
                a = p[_P_A0]  # exp(−ε·Tc), precomputed (|η| <= m1)
            else:
                a = np.exp(-lam * Tc)
            e = e * a - 0.5 * (x4 + x4p) * (1.0 - a) / lam
            st[1 + c] = e
        xb = x3 + e
        eta = x1 - x3
        m1 = p[_P_M1]
        if eta > m1:  # φ = (d/m2)⁴, φ' = 4d³/m2⁴, φ'' = 12d²/m2⁴, φ‴ = 24d/m2⁴
            d = eta - m1
        elif eta < -m1:
            d = eta + m1
        else:
            d = 0.0
        k4 = p[_P_K4]
        P0 = math.pow(d, four) * k4
        P1 = 4 * math.pow(d, three) * k4
        P2 = 12 * (d * d) * k4
        P3 = 24 * d * k4
        D = p[_P_PS] - sign(x6) * x5
        w3 = sign(D) * np.sqrt(np.abs(D))
        g = p[_P_G]
        if np.abs(w3) < g:
            w3g = g if w3 >= 0 else -g
        else:
            w3g = w3
        S = x6 * w3
        Q = np.abs(x6) / (2.0 * np.abs(w3g))
        th = st[1 + 3 * nc + c]
        (z1, z2, z3, z4, alpha3, omega4, tau4, thdot, h3, h4, R3, R4, d3, d4, alpha4_rest) = _lin_eval(
            two, three, mode, x1, x2, x3, x4, x5, xb, P0, P1, P2, P3, th, S, Q,
            p[q], p[q + 1], p[q + 2], p[q + 3], p[q + 4], p[q + 5], p[q + 6], p[q + 7], p[q + 8], p[q + 9],
            p[q + 10], p[q + 11], p[q + 12], p[q + 13], p[q + 14], p[q + 15], p[q + 16], p[q + 17])
        tau = p[_P_TAU]
        alpha4 = x6 * w3 / tau + alpha4_rest
        uc = tau * alpha4 / w3g
        st[1 + nc + c] = p[_P_EPS] + p[_P_EPS1] * P0
        st[1 + 2 * nc + c] = x4
        st[1 + 3 * nc + c] = th + p[_P_ADAPT] * Tc * thdot
        o = 1 + 4 * nc
        st[o + c] = z1
        st[o + nc + c] = z2
        st[o + 2 * nc + c] = z3
        st[o + 3 * nc + c] = z4
        st[o + 4 * nc + c] = p[q + 8] * th  # ρ·θ̂ before the update
        st[o + 5 * nc + c] = -(x2 - x4)
        st[o + 6 * nc + c] = omega4
        st[o + 7 * nc + c] = h3
        st[o + 8 * nc + c] = h4
        st[o + 9 * nc + c] = R3
        st[o + 10 * nc + c] = R4
        st[o + 11 * nc + c] = d3
        st[o + 12 * nc + c] = d4
        st[o + 13 * nc + c] = P0
        st[o + 14 * nc + c] = uc
        u[c] = uc
    st[0] = 1.0


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
    eps1: float = Field(0.01, ge=0, description="filter constant ε1 (1/s); not printed, reconstructed from "
                        "the paper's figure axes (see the module docstring)")
    m1: float = Field(0.055, ge=0, description="filter threshold m1 (m)")
    m2: float = Field(0.005, gt=0, description="filter scale m2 (m)")
    adaptation_gain: float = Field(40.0, ge=0, description="Γ of Eq. (12)")
    adaptive: bool = Field(True, description="update θ̂ (False: non-adaptive, θ̂ = α·A fixed)")
    w3_guard: float = Field(1.0, gt=0, description="|w3| below this is replaced by ±w3_guard in denominators")


@CONTROLLERS.register("lin_kanellakopoulos")
class LinKanellakopoulos(Controller):
    """Lin & Kanellakopoulos (1996): adaptive backstepping (tuning functions, θ = α·A) with the nonlinear
    travel filter; command = spool input (m).  See the module docstring."""

    Params = LinKanellakopoulosParams
    requires = ("travel", "wheel_pos", "corner_body_vel", "wheel_vel", "load_pressure", "spool_position")
    kernel = staticmethod(_kernel)

    _NAMES = {"Mb": "sprung_mass", "Mus": "unsprung_mass", "Ka": "spring_stiffness", "Ca": "damping",
              "Kt": "tire_stiffness", "A": "area", "beta": "beta", "gam": "gamma", "rho": "rho", "c1": "c1",
              "c2": "c2", "c3": "c3", "c4": "c4", "b3": "b3", "b4": "b4", "eps": "eps", "eps1": "eps1",
              "Gam": "adaptation_gain"}

    def kernel_data(self):
        n, nc, p, col = self.ctx.n_cars, self.ctx.n_corners, self.p, self.per_car

        P = np.zeros((n, _NPH + len(_PARAM)))
        for j, name in ((_P_OTRAV, "travel"), (_P_OWPOS, "wheel_pos"), (_P_OVB, "corner_body_vel"),
                        (_P_OVW, "wheel_vel"), (_P_OPL, "load_pressure"), (_P_OXV, "spool_position")):
            P[:, j] = self.ctx.reading_start(name)
        P[:, _P_M1] = col(p.m1)
        P[:, _P_K4] = col(1.0 / p.m2 ** 4)
        P[:, _P_PS], P[:, _P_G], P[:, _P_TAU] = col(p.supply_pressure), col(p.w3_guard), col(p.spool_time_constant)
        P[:, _P_EPS], P[:, _P_EPS1] = col(p.eps), col(p.eps1)
        Tc = self.ctx.control_dt
        P[:, _P_TC] = Tc
        P[:, _P_ADAPT] = col(p.adaptive)
        P[:, _P_A0] = np.exp(-col(p.eps + p.eps1 * 0.0) * Tc)  # the filter's e^(−λ·Tc) for |η| <= m1
        P[:, _P_MODE] = 0.0 if n * nc <= 8 else 1.0
        P[:, _P_TWO], P[:, _P_THREE], P[:, _P_FOUR] = 2.0, 3.0, 4.0
        for j, k in enumerate(_PARAM):
            P[:, _NPH + j] = col(getattr(p, self._NAMES[k]))
        S = np.zeros((n, 1 + len(_ST) * nc))
        k = _ST.index("th")
        S[:, 1 + k * nc:1 + (k + 1) * nc] = (np.asarray(p.alpha, float) * np.asarray(p.area, float)).reshape(-1, 1)
        return P, S

    def kernel_signals(self):
        nc = self.ctx.n_corners
        return {name: (1 + _ST.index(name) * nc, 1 + (_ST.index(name) + 1) * nc) for name in _SIG}


if __name__ == "__main__":  # python -m controllers.lin_kanellakopoulos: rewrite the GENERATED block
    from pathlib import Path

    path = Path(__file__)
    text = path.read_text()
    a, b = "# --- GENERATED by kernel_source(), do not edit ---\n", "# --- END GENERATED ---\n"
    i, j = text.index(a) + len(a), text.index(b)
    path.write_text(text[:i] + kernel_source() + text[j:])
