"""A light, compiled simulator of the diagnosable models (quarter car, SDOF rig, damper element) driven by
measured inputs, used for the many simulations of the fitting and the candidate search.

Why not MuJoCo for the search: a 60 s record at 1 kHz takes about 1–2 s through the MuJoCo loop (a
Python call per physics step), and output-error fitting of a dozen candidates needs thousands of
simulations.  This kernel (numba, RK4 on the mechanical states) runs the same record in a few
milliseconds, and :func:`simulate_batch` runs many parameter sets in parallel (finite-difference
Jacobians).  The force laws are the same as the effect classes in :mod:`suspension_sim.effects`
(tests/test_diagnose.py checks each against ``Effect.force``), and the fitted model is re-simulated in
MuJoCo at the end as a confirmation (:mod:`suspension_sim.diagnose.confirm`).

Models (positions from static equilibrium, travel ``s`` = body − wheel, positive = extension; effect forces
positive push the body up):

- quarter car: ``m_s·z̈_s = F``, ``m_u·z̈_u = −F + F_t`` with the suspension force
  ``F = −k·s − c·ṡ + Σ effects + F_a`` and the (dynamic) tire force ``F_t = −k_t·(z_u − r) − c_t·(ż_u − ṙ)``
  (+ the lift-off correction that keeps the total tire force ``F_static + F_t`` ≥ 0);
- SDOF rig: ``m·z̈ = F`` with ``s = z − base``;
- damper element: the measured (resisting) force is ``−F`` at the prescribed displacement and velocity;
- half car (:func:`simulate_half`): bounce ``z_s`` and pitch ``θ`` (positive = nose down) of the body, front
  wheel at ``x = +a`` and rear wheel at ``x = −b``; each corner is a quarter car's suspension and tire with
  its own nominal parameters (front: the quarter-car slots, rear: ``*_R``) and the body at the corner at
  ``z_s − x·θ``: ``M·z̈_s = F_f + F_r``, ``I·θ̈ = −a·F_f + b·F_r``.  Every effect acts at both corners with
  the same parameters (its own hysteresis/backlash state per corner); the force inputs ``force_front`` /
  ``force_rear`` share the gain, offset, delay and lag.

The actuator force is ``F_a`` = lag(delay(gain·u + offset)) of the measured force input ``u``.  Stateful
effects (Bouc–Wen hysteresis, backlash) are rate independent, so their states are advanced exactly from the
travel increment of each sub-step.
"""
from __future__ import annotations

import math

import numba as nb
import numpy as np

G = 9.81
# parameter slots
MS, MU, K, C, KT, CT, GAIN, OFFS, CF, VEPS, CV, CCOMP, CREB, GAP, KSTOP, K3, LIFT, DELAY, TAU, BWF, BWX, BLK, BLB = range(23)
DX0 = 23  # 23..26: corrections added to the initial state (z_s, ż_s, z_u, ż_u), fitted as nuisance parameters
# half car: the front corner uses MU, K, C, KT, CT; these slots hold the pitch inertia, the axle distances and
# the rear corner's parameters
IYY, HA, HB, MU_R, K_R, C_R, KT_R, CT_R = range(27, 35)
SUB = 35  # sub-step refinement factor (≥ 1) a parameter set asks for (a sharp friction law needs smaller steps)
NP = 36
SLOTS = ["sprung_mass", "unsprung_mass", "spring_stiffness", "damping", "tire_stiffness", "tire_damping",
         "force_gain", "force_offset", "cf_force", "cf_v_eps", "qd_c_v", "as_c_comp", "as_c_reb", "bs_gap",
         "bs_stiffness", "cs_k3", "tl_on", "act_delay", "act_tau", "bw_force", "bw_x_y", "bl_stiffness", "bl_play",
         "dx0_zs", "dx0_vs", "dx0_zu", "dx0_vu", "pitch_inertia", "a", "b", "unsprung_mass_rear",
         "spring_stiffness_rear", "damping_rear", "tire_stiffness_rear", "tire_damping_rear", "substep_factor"]
KINDS = {"quarter_car": 0, "sdof": 1, "damper": 2, "half_car": 3}
CHANNELS = {
    "quarter_car": ["body_acc", "wheel_acc", "susp_travel", "body_pos", "wheel_pos", "tire_force"],
    "sdof": ["acc", "vel", "pos"],
    "damper": ["force"],
    "half_car": [f"{n}_{e}" for e in ("front", "rear") for n in
                 ("body_acc", "wheel_acc", "susp_travel", "body_pos", "wheel_pos", "tire_force")] + ["pitch", "pitch_rate"],
}


@nb.njit(cache=True, inline="always")
def _interp(arr, x):
    n = arr.shape[0]
    if x <= 0.0:
        return arr[0]
    if x >= n - 1:
        return arr[n - 1]
    i = int(x)
    f = x - i
    return arr[i] * (1.0 - f) + arr[i + 1] * f


@nb.njit(cache=True, fastmath=True)
def susp_force(P, s, v, w, y):
    """Sum of the linear spring/damper and every effect acting on the suspension (no actuator)."""
    return susp_force_kc(P, P[K], P[C], s, v, w, y)


@nb.njit(cache=True, fastmath=True)
def susp_force_kc(P, kk, cc, s, v, w, y):
    """:func:`susp_force` with the linear stiffness ``kk`` and damping ``cc`` given (half car: per corner)."""
    F = -kk * s - cc * v
    if P[CF] != 0.0:
        F -= P[CF] * math.tanh(v / P[VEPS])
    if P[CV] != 0.0:
        F -= P[CV] * v * abs(v)
    if v > 0.0:
        F -= P[CREB] * v
    else:
        F -= P[CCOMP] * v
    if P[KSTOP] != 0.0:
        pc = -P[GAP] - s
        pe = s - P[GAP]
        if pc > 0.0:
            F += P[KSTOP] * pc
        if pe > 0.0:
            F -= P[KSTOP] * pe
    if P[K3] != 0.0:
        F -= P[K3] * s * s * s
    if P[BWF] != 0.0:
        F -= P[BWF] * w
    if P[BLK] != 0.0:
        F -= P[BLK] * y
    return F


@nb.njit(cache=True, fastmath=True)
def bouc_wen_step(w, ds, x_y):
    """Exact update of the Bouc–Wen state (n = 1, β = γ = 1/2) for a travel increment ``ds``:
    dw/ds = (1 − |w|·(γ + β·sgn(ds·w))) / x_y, i.e. linear while unloading, 1 − e^(−s/x_y) while loading."""
    if ds == 0.0:
        return w
    sg = 1.0 if ds > 0.0 else -1.0
    a = abs(ds) / x_y
    u = sg * w
    if u < 0.0:
        if u + a <= 0.0:
            return sg * (u + a)
        a -= -u
        u = 0.0
    u = 1.0 - (1.0 - u) * math.exp(-a)
    return sg * u


@nb.njit(cache=True, fastmath=True)
def play_step(y, s, b):
    """Backlash (play operator) of half-width ``b``: the driven side follows ``s`` with a lag of ``b``."""
    if s - b > y:
        return s - b
    if s + b < y:
        return s + b
    return y


@nb.njit(cache=True, fastmath=True)
def _hyst_states(P, s, s_old, w, y):
    """Bouc–Wen and backlash states at travel ``s`` on the way from ``s_old`` (exact: both are rate
    independent), so every RK4 stage sees the hysteretic force of its own travel."""
    ws = bouc_wen_step(w, s - s_old, P[BWX]) if P[BWF] != 0.0 else w
    ys = play_step(y, s, P[BLB]) if P[BLK] != 0.0 else y
    return ws, ys


@nb.njit(cache=True, fastmath=True)
def _deriv(kind, P, x, tidx, road, roaddot, Fa, w, y, Fs, s_old):
    zs, vs, zu, vu = x[0], x[1], x[2], x[3]
    r = _interp(road, tidx)
    if kind == 0:
        s = zs - zu
        v = vs - vu
        ws, ys = _hyst_states(P, s, s_old, w, y)
        F = susp_force(P, s, v, ws, ys) + Fa
        rd = _interp(roaddot, tidx)
        xt = zu - r
        xtd = vu - rd
        Ft = -P[KT] * xt - P[CT] * xtd
        if P[LIFT] != 0.0:
            pull = P[KT] * xt + P[CT] * xtd - Fs
            if pull > 0.0:
                Ft += pull
        return vs, F / P[MS], vu, (-F + Ft) / P[MU], Ft
    else:
        rd = _interp(roaddot, tidx)
        s = zs - r
        v = vs - rd
        ws, ys = _hyst_states(P, s, s_old, w, y)
        F = susp_force(P, s, v, ws, ys) + Fa
        return vs, F / P[MS], 0.0, 0.0, 0.0


@nb.njit(cache=True, fastmath=True)
def _cmd(P, force, tidx, inv_dt):
    return P[GAIN] * _interp(force, tidx - P[DELAY] * inv_dt) + P[OFFS]


@nb.njit(cache=True, nogil=True, fastmath=True)
def simulate_one(kind, P, road, roaddot, force, dt, nsub, x0, out):
    """Simulate one parameter set; fills ``out`` (N, n_channels) with the channels of :data:`CHANNELS`."""
    n = road.shape[0]
    inv_dt = 1.0 / dt
    nsub = nsub * max(1, int(P[SUB] + 0.5))
    h = dt / nsub
    hi = 1.0 / nsub  # sub-step in sample-index units
    Fs = (P[MS] + P[MU]) * G
    x = np.empty(4)
    for k in range(4):
        x[k] = x0[k] + P[DX0 + k]
    xk = np.empty(4)
    w = 0.0
    yb = 0.0
    lag = P[TAU] > 0.0
    a_lag = math.exp(-h / P[TAU]) if lag else 0.0
    Fa = _cmd(P, force, 0.0, inv_dt)
    if kind == 2:
        for i in range(n):
            s = road[i]
            v = roaddot[i]
            if i > 0:
                ds = s - road[i - 1]
                if P[BWF] != 0.0:
                    w = bouc_wen_step(w, ds, P[BWX])
                if P[BLK] != 0.0:
                    yb = play_step(yb, s, P[BLB])
            out[i, 0] = -susp_force(P, s, v, w, yb)
        return
    for i in range(n):
        # outputs at sample i
        ti = float(i)
        Fa_i = Fa if lag else _cmd(P, force, ti, inv_dt)
        s_i = x[0] - (x[2] if kind == 0 else _interp(road, ti))
        d0, d1, d2, d3, Ft = _deriv(kind, P, x, ti, road, roaddot, Fa_i, w, yb, Fs, s_i)
        if kind == 0:
            out[i, 0] = d1
            out[i, 1] = d3
            out[i, 2] = x[0] - x[2]
            out[i, 3] = x[0]
            out[i, 4] = x[2]
            out[i, 5] = Ft
        else:
            out[i, 0] = d1
            out[i, 1] = x[1]
            out[i, 2] = x[0]
        if i == n - 1:
            break
        for j in range(nsub):
            t0 = ti + j * hi
            if lag:
                Fa = a_lag * Fa + (1.0 - a_lag) * _cmd(P, force, t0, inv_dt)
                f0 = f1 = f2 = Fa
            else:
                f0 = _cmd(P, force, t0, inv_dt)
                f1 = _cmd(P, force, t0 + 0.5 * hi, inv_dt)
                f2 = _cmd(P, force, t0 + hi, inv_dt)
            s_old = x[0] - (x[2] if kind == 0 else _interp(road, t0))
            k10, k11, k12, k13, _ = _deriv(kind, P, x, t0, road, roaddot, f0, w, yb, Fs, s_old)
            xk[0] = x[0] + 0.5 * h * k10
            xk[1] = x[1] + 0.5 * h * k11
            xk[2] = x[2] + 0.5 * h * k12
            xk[3] = x[3] + 0.5 * h * k13
            k20, k21, k22, k23, _ = _deriv(kind, P, xk, t0 + 0.5 * hi, road, roaddot, f1, w, yb, Fs, s_old)
            xk[0] = x[0] + 0.5 * h * k20
            xk[1] = x[1] + 0.5 * h * k21
            xk[2] = x[2] + 0.5 * h * k22
            xk[3] = x[3] + 0.5 * h * k23
            k30, k31, k32, k33, _ = _deriv(kind, P, xk, t0 + 0.5 * hi, road, roaddot, f1, w, yb, Fs, s_old)
            xk[0] = x[0] + h * k30
            xk[1] = x[1] + h * k31
            xk[2] = x[2] + h * k32
            xk[3] = x[3] + h * k33
            k40, k41, k42, k43, _ = _deriv(kind, P, xk, t0 + hi, road, roaddot, f2, w, yb, Fs, s_old)
            x[0] += h / 6.0 * (k10 + 2 * k20 + 2 * k30 + k40)
            x[1] += h / 6.0 * (k11 + 2 * k21 + 2 * k31 + k41)
            x[2] += h / 6.0 * (k12 + 2 * k22 + 2 * k32 + k42)
            x[3] += h / 6.0 * (k13 + 2 * k23 + 2 * k33 + k43)
            if P[BWF] != 0.0 or P[BLK] != 0.0:
                s_new = x[0] - (x[2] if kind == 0 else _interp(road, t0 + hi))
                if P[BWF] != 0.0:
                    w = bouc_wen_step(w, s_new - s_old, P[BWX])
                if P[BLK] != 0.0:
                    yb = play_step(yb, s_new, P[BLB])
        if not (abs(x[0]) < 1e6 and abs(x[1]) < 1e9):
            for k in range(i + 1, n):
                for c in range(out.shape[1]):
                    out[k, c] = 1e6
            return


@nb.njit(cache=True, fastmath=True)
def _half_deriv(P, x, tidx, rf, rfd, rr, rrd, Faf, Far, wf, yf, wr, yr, sf_old, sr_old, out):
    """Half car: x = (z_s, ż_s, θ, θ̇, z_uf, ż_uf, z_ur, ż_ur), pitch positive = nose down, so the body at a
    corner at x_c (front +a, rear −b) is at z_s − x_c·θ.  Every effect acts at both corners with the same
    parameters (its own hysteresis/backlash state per corner).  Fills out[0:8] with ẋ, out[8:10] with the
    dynamic tire forces."""
    a, b = P[HA], P[HB]
    zs, vs, th, om = x[0], x[1], x[2], x[3]
    sf = zs - a * th - x[4]
    vf = vs - a * om - x[5]
    sr = zs + b * th - x[6]
    vr = vs + b * om - x[7]
    wsf, ysf = _hyst_states(P, sf, sf_old, wf, yf)
    wsr, ysr = _hyst_states(P, sr, sr_old, wr, yr)
    Ff = susp_force_kc(P, P[K], P[C], sf, vf, wsf, ysf) + Faf
    Fr = susp_force_kc(P, P[K_R], P[C_R], sr, vr, wsr, ysr) + Far
    L = a + b
    r_f = _interp(rf, tidx)
    r_r = _interp(rr, tidx)
    xtf = x[4] - r_f
    xtfd = x[5] - _interp(rfd, tidx)
    xtr = x[6] - r_r
    xtrd = x[7] - _interp(rrd, tidx)
    Ftf = -P[KT] * xtf - P[CT] * xtfd
    Ftr = -P[KT_R] * xtr - P[CT_R] * xtrd
    if P[LIFT] != 0.0:
        Fsf = (P[MS] * b / L + P[MU]) * G
        Fsr = (P[MS] * a / L + P[MU_R]) * G
        pf = -Ftf - Fsf
        if pf > 0.0:
            Ftf += pf
        pr = -Ftr - Fsr
        if pr > 0.0:
            Ftr += pr
    out[0] = vs
    out[1] = (Ff + Fr) / P[MS]
    out[2] = om
    out[3] = (-a * Ff + b * Fr) / P[IYY]
    out[4] = x[5]
    out[5] = (-Ff + Ftf) / P[MU]
    out[6] = x[7]
    out[7] = (-Fr + Ftr) / P[MU_R]
    out[8] = Ftf
    out[9] = Ftr


@nb.njit(cache=True, nogil=True, fastmath=True)
def simulate_half(P, rf, rfd, rr, rrd, uf, ur, dt, nsub, x0, out):
    """Half-car simulation (RK4 with sub-steps); ``out`` (N, 14) in the order of :data:`CHANNELS` ["half_car"].
    The force inputs ``uf``/``ur`` act at the front/rear corner through the same gain, offset, delay and lag."""
    n = rf.shape[0]
    inv_dt = 1.0 / dt
    nsub = nsub * max(1, int(P[SUB] + 0.5))
    h = dt / nsub
    hi = 1.0 / nsub
    a, b = P[HA], P[HB]
    x = np.empty(8)
    for k in range(8):
        x[k] = x0[k]
    xk = np.empty(8)
    d1 = np.empty(10)
    d2 = np.empty(10)
    d3 = np.empty(10)
    d4 = np.empty(10)
    wf = yf = wr = yr = 0.0
    lag = P[TAU] > 0.0
    a_lag = math.exp(-h / P[TAU]) if lag else 0.0
    Faf = _cmd(P, uf, 0.0, inv_dt)
    Far = _cmd(P, ur, 0.0, inv_dt)
    hyst = P[BWF] != 0.0 or P[BLK] != 0.0
    for i in range(n):
        ti = float(i)
        ff = Faf if lag else _cmd(P, uf, ti, inv_dt)
        fr = Far if lag else _cmd(P, ur, ti, inv_dt)
        sf = x[0] - a * x[2] - x[4]
        sr = x[0] + b * x[2] - x[6]
        _half_deriv(P, x, ti, rf, rfd, rr, rrd, ff, fr, wf, yf, wr, yr, sf, sr, d1)
        acc_th = d1[3]
        out[i, 0] = d1[1] - a * acc_th
        out[i, 1] = d1[5]
        out[i, 2] = sf
        out[i, 3] = x[0] - a * x[2]
        out[i, 4] = x[4]
        out[i, 5] = d1[8]
        out[i, 6] = d1[1] + b * acc_th
        out[i, 7] = d1[7]
        out[i, 8] = sr
        out[i, 9] = x[0] + b * x[2]
        out[i, 10] = x[6]
        out[i, 11] = d1[9]
        out[i, 12] = x[2]
        out[i, 13] = x[3]
        if i == n - 1:
            break
        for j in range(nsub):
            t0 = ti + j * hi
            if lag:
                Faf = a_lag * Faf + (1.0 - a_lag) * _cmd(P, uf, t0, inv_dt)
                Far = a_lag * Far + (1.0 - a_lag) * _cmd(P, ur, t0, inv_dt)
                f0 = f1 = f2 = Faf
                g0 = g1 = g2 = Far
            else:
                f0 = _cmd(P, uf, t0, inv_dt)
                f1 = _cmd(P, uf, t0 + 0.5 * hi, inv_dt)
                f2 = _cmd(P, uf, t0 + hi, inv_dt)
                g0 = _cmd(P, ur, t0, inv_dt)
                g1 = _cmd(P, ur, t0 + 0.5 * hi, inv_dt)
                g2 = _cmd(P, ur, t0 + hi, inv_dt)
            sf_old = x[0] - a * x[2] - x[4]
            sr_old = x[0] + b * x[2] - x[6]
            _half_deriv(P, x, t0, rf, rfd, rr, rrd, f0, g0, wf, yf, wr, yr, sf_old, sr_old, d1)
            for k in range(8):
                xk[k] = x[k] + 0.5 * h * d1[k]
            _half_deriv(P, xk, t0 + 0.5 * hi, rf, rfd, rr, rrd, f1, g1, wf, yf, wr, yr, sf_old, sr_old, d2)
            for k in range(8):
                xk[k] = x[k] + 0.5 * h * d2[k]
            _half_deriv(P, xk, t0 + 0.5 * hi, rf, rfd, rr, rrd, f1, g1, wf, yf, wr, yr, sf_old, sr_old, d3)
            for k in range(8):
                xk[k] = x[k] + h * d3[k]
            _half_deriv(P, xk, t0 + hi, rf, rfd, rr, rrd, f2, g2, wf, yf, wr, yr, sf_old, sr_old, d4)
            for k in range(8):
                x[k] += h / 6.0 * (d1[k] + 2 * d2[k] + 2 * d3[k] + d4[k])
            if hyst:
                sf_new = x[0] - a * x[2] - x[4]
                sr_new = x[0] + b * x[2] - x[6]
                if P[BWF] != 0.0:
                    wf = bouc_wen_step(wf, sf_new - sf_old, P[BWX])
                    wr = bouc_wen_step(wr, sr_new - sr_old, P[BWX])
                if P[BLK] != 0.0:
                    yf = play_step(yf, sf_new, P[BLB])
                    yr = play_step(yr, sr_new, P[BLB])
        if not (abs(x[0]) < 1e6 and abs(x[1]) < 1e9 and abs(x[3]) < 1e9):
            for k in range(i + 1, n):
                for c in range(out.shape[1]):
                    out[k, c] = 1e6
            return


@nb.njit(cache=True, parallel=True)
def simulate_half_batch(Pm, rf, rfd, rr, rrd, uf, ur, dt, nsub, x0m, out):
    for b in nb.prange(Pm.shape[0]):
        simulate_half(Pm[b], rf, rfd, rr, rrd, uf, ur, dt, nsub, x0m[b], out[b])


@nb.njit(cache=True, nogil=True)
def simulate_half_batch_serial(Pm, rf, rfd, rr, rrd, uf, ur, dt, nsub, x0m, out):
    for b in range(Pm.shape[0]):
        simulate_half(Pm[b], rf, rfd, rr, rrd, uf, ur, dt, nsub, x0m[b], out[b])


@nb.njit(cache=True, parallel=True)
def simulate_batch(kind, Pm, road, roaddot, force, dt, nsub, x0m, out):
    for b in nb.prange(Pm.shape[0]):
        simulate_one(kind, Pm[b], road, roaddot, force, dt, nsub, x0m[b], out[b])


@nb.njit(cache=True, nogil=True)
def simulate_batch_serial(kind, Pm, road, roaddot, force, dt, nsub, x0m, out):
    for b in range(Pm.shape[0]):
        simulate_one(kind, Pm[b], road, roaddot, force, dt, nsub, x0m[b], out[b])


def default_params() -> np.ndarray:
    P = np.zeros(NP)
    P[GAIN] = 1.0
    P[VEPS] = 0.01
    P[BWX] = 0.01
    P[MS] = P[MU] = 1.0
    P[IYY] = P[HA] = P[HB] = P[MU_R] = 1.0
    P[SUB] = 1.0
    return P


def run(kind: str, P: np.ndarray, inputs: dict, dt: float, nsub: int, x0=None) -> np.ndarray:
    """Simulate; returns (N, n_channels) ordered as :data:`CHANNELS` [kind]."""
    road, roaddot, force = inputs["road"], inputs["roaddot"], inputs["force"]
    out = np.empty((len(road), len(CHANNELS[kind])))
    if kind == "half_car":
        x0 = np.zeros(8) if x0 is None or len(x0) != 8 else np.asarray(x0, float)
        simulate_half(np.asarray(P, float), road, roaddot, inputs["road_r"], inputs["roaddot_r"], force,
                      inputs["force_r"], dt, nsub, x0, out)
        return out
    x0 = np.zeros(4) if x0 is None else np.asarray(x0, float)
    simulate_one(KINDS[kind], np.asarray(P, float), road, roaddot, force, dt, nsub, x0, out)
    return out


def run_batch(kind: str, Pm: np.ndarray, inputs: dict, dt: float, nsub: int, x0=None,
              parallel: bool = True) -> np.ndarray:
    road, roaddot, force = inputs["road"], inputs["roaddot"], inputs["force"]
    Pm = np.ascontiguousarray(Pm, dtype=float)
    out = np.empty((Pm.shape[0], len(road), len(CHANNELS[kind])))
    if kind == "half_car":
        x0 = np.zeros(8) if x0 is None or len(x0) != 8 else np.asarray(x0, float)
        x0m = np.ascontiguousarray(np.broadcast_to(x0, (Pm.shape[0], 8)))
        (simulate_half_batch if parallel else simulate_half_batch_serial)(
            Pm, road, roaddot, inputs["road_r"], inputs["roaddot_r"], force, inputs["force_r"], dt, nsub, x0m, out)
        return out
    x0 = np.zeros(4) if x0 is None else np.asarray(x0, float)
    x0m = np.ascontiguousarray(np.broadcast_to(x0, (Pm.shape[0], 4)))
    (simulate_batch if parallel else simulate_batch_serial)(KINDS[kind], Pm, road, roaddot, force, dt, nsub, x0m, out)
    return out
