"""Synthetic "measured" records with a hidden effect, for testing and benchmarking the discrepancy workflow
ONLY (the workflow itself never imports this module).

The truth is integrated by scipy ``solve_ivp`` (DOP853, step ≤ the sample interval) with its own,
independent implementation of every effect (written from the physics, sharing no code with
:mod:`suspension_sim.effects` or :mod:`.fastsim`); inputs are random continuous functions of time (sums of
random sines: a road and a force command); sensor noise is white and Gaussian.  Coulomb friction uses
``tanh(v/2 mm/s)`` here, sharper than the fitted model's regularisation, and the actuator delay is exact
(the input function evaluated at ``t − d``), so the fitted model never has the truth's exact form.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81

QC_NOMINAL = {"sprung_mass": 290.0, "unsprung_mass": 59.0, "spring_stiffness": 16812.0, "damping": 1000.0,
              "tire_stiffness": 190000.0, "tire_damping": 0.0}
SDOF_NOMINAL = {"sprung_mass": 250.0, "spring_stiffness": 5000.0, "damping": 250.0}


def random_signal(rng, duration, f_lo, f_hi, rms, n_lines=40):
    """A random continuous signal (sum of sines with random frequencies in [f_lo, f_hi], 1/f amplitudes for a
    road-like spectrum) and its derivative, as functions of t; RMS ≈ ``rms``."""
    f = np.exp(rng.uniform(np.log(f_lo), np.log(f_hi), n_lines))
    a = 1.0 / f ** 0.5
    a *= rms / np.sqrt(0.5 * np.sum(a ** 2))
    ph = rng.uniform(0, 2 * np.pi, n_lines)
    w = 2 * np.pi * f

    def x(t):
        t = np.asarray(t, float)
        return np.sum(a[:, None] * np.sin(w[:, None] * np.atleast_1d(t)[None, :] + ph[:, None]), axis=0).reshape(t.shape)

    def xd(t):
        t = np.asarray(t, float)
        return np.sum((a * w)[:, None] * np.cos(w[:, None] * np.atleast_1d(t)[None, :] + ph[:, None]), axis=0).reshape(t.shape)

    ramp = min(1.0, duration / 10)
    # tabulate on a fine grid (16 points per sample of a 1 kHz record) for fast evaluation in the ODE
    h = 1.0 / 16000.0
    tg = np.arange(-0.5, duration + 1.0, h)
    env = np.clip(tg / ramp, 0, 1)
    xg = x(tg) * env
    xdg = xd(tg) * env + x(tg) * ((tg >= 0) & (tg < ramp)) / ramp
    return _Tab(tg[0], h, xg), _Tab(tg[0], h, xdg)


class _Tab:
    """A tabulated function of time, linearly interpolated (scalar calls are fast)."""

    def __init__(self, t0, h, y):
        self.t0, self.h, self.y, self.n = t0, h, y, len(y)

    def __call__(self, t):
        if np.ndim(t) == 0:
            u = (float(t) - self.t0) / self.h
            i = min(max(int(u), 0), self.n - 2)
            f = u - i
            return self.y[i] * (1 - f) + self.y[i + 1] * f
        return np.interp(np.asarray(t, float), self.t0 + self.h * np.arange(self.n), self.y)


def _suspension_extra(effects: dict, s, v, st):
    """Extra suspension force of the hidden effects (positive pushes the body up). ``st`` = internal states."""
    F = 0.0
    for name, p in effects.items():
        if name == "coulomb_friction":
            F += -p["force"] * math.tanh(v / 0.002)
        elif name == "quadratic_damping":
            F += -p["c_v"] * v * abs(v)
        elif name == "asymmetric_damping":
            F += -(p.get("c_reb", 0.0) if v > 0 else p.get("c_comp", 0.0)) * v
        elif name == "bump_stop":  # gap_compression / gap_extension (None: no stop that side) default to gap
            # optional contact damping c while engaged; the stop pushes, never pulls
            k, c = p["stiffness"], p.get("damping", 0.0)
            gc, ge = p.get("gap_compression", p.get("gap")), p.get("gap_extension", p.get("gap"))
            if ge is not None and s > ge:
                F += min(0.0, -k * (s - ge) - c * v)
            elif gc is not None and s < -gc:
                F += max(0.0, k * (-gc - s) - c * v)
        elif name == "cubic_stiffness":
            F += -p["k3"] * s ** 3
        elif name == "hysteresis":
            F += -p["force"] * st["w"]
        elif name == "backlash":
            F += -p["stiffness"] * st["y"]
        elif name == "stroke_damping":  # not in the library: damping that grows with the stroke, −c_s·s²·v
            F += -p["c_s"] * s * s * v
    return F


def simulate_truth(kind: str, duration: float, fs: float, effects: dict, params: dict | None = None,
                   seed: int = 0, road_rms: float = 0.01, force_rms: float = 0.0, noise: float = 0.01,
                   outputs: list[str] | None = None, band=(0.3, 15.0)):
    """A synthetic record: dict with ``time``, inputs and noisy outputs (noise std = ``noise`` × the channel's
    std), plus ``_clean`` (noise-free outputs).  ``kind``: quarter_car, sdof or damper.  ``effects`` maps
    effect names to parameters; ``actuator_delay`` {delay} and ``actuator_lag`` {time_constant} act on the
    force input."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * fs))) / fs
    p = dict(QC_NOMINAL if kind == "quarter_car" else SDOF_NOMINAL)
    p.update(params or {})
    road, roadd = random_signal(rng, duration, band[0], band[1], road_rms) if road_rms > 0 else (
        (lambda tt: np.zeros_like(np.asarray(tt, float))),) * 2
    force, _ = random_signal(rng, duration, band[0], band[1] * 1.5, force_rms) if force_rms > 0 else (
        (lambda tt: np.zeros_like(np.asarray(tt, float))), None)
    delay = effects.get("actuator_delay", {}).get("delay", 0.0)
    tau = effects.get("actuator_lag", {}).get("time_constant", 0.0)
    eff = {k: v for k, v in effects.items() if not k.startswith("actuator_")}
    lift = "tire_liftoff" in eff

    if kind == "damper":
        if "maxwell_damper" in eff:
            raise ValueError("the damper-element truth does not implement maxwell_damper")
        amp = road_rms if road_rms > 0 else 0.02
        d, dd = random_signal(rng, duration, 0.2, 5.0, amp)
        s, v = d(t), dd(t)
        st = {"w": 0.0, "y": 0.0}
        F = np.empty_like(t)
        for i in range(len(t)):
            if i:
                ds = s[i] - s[i - 1]
                # Bouc–Wen by sub-divided explicit steps on the travel increment
                if "hysteresis" in eff:
                    xy = eff["hysteresis"]["x_y"]
                    for _ in range(20):
                        w = st["w"]
                        st["w"] = w + ds / 20 / xy * (1 - abs(w) * (0.5 + 0.5 * np.sign(ds * w)))
                if "backlash" in eff:
                    b = eff["backlash"]["play"]
                    st["y"] = min(max(st["y"], s[i] - b), s[i] + b)
            F[i] = p.get("spring_stiffness", 0.0) * s[i] + p["damping"] * v[i] - _suspension_extra(eff, s[i], v[i], st)
        clean = {"force": F}
        ins = {"disp": s, "vel": v}
    else:
        qc = kind == "quarter_car"
        ms, k, c = p["sprung_mass"], p["spring_stiffness"], p["damping"]
        mu, kt, ct = (p["unsprung_mass"], p["tire_stiffness"], p["tire_damping"]) if qc else (0, 0, 0)
        Fst = (ms + mu) * G

        def u_act(tt):
            return float(force(tt - delay)) if tt - delay >= 0 else float(force(0.0))

        # a Maxwell damper (maxwell_damper {compliance h}): the damper c in series with a spring 1/h, its force R
        # obeying dR/dt = (v − R/c)/h, in place of the damper's c·v
        hm = eff.get("maxwell_damper", {}).get("compliance", 0.0)

        # state: zs, vs, zu, vu, w (Bouc–Wen), y (backlash), Fa (lag), R (the Maxwell damper's force)
        def rhs(tt, x):
            zs, vs, zu, vu, w, yb, Fa, R = x
            r, rd = float(road(tt)), float(roadd(tt))
            if qc:
                s, v = zs - zu, vs - vu
            else:
                s, v = zs - r, vs - rd
            Fact = Fa if tau > 0 else u_act(tt)
            F = -k * s - (R if hm > 0 else c * v) + _suspension_extra(eff, s, v, {"w": w, "y": yb}) + Fact
            dR = (v - R / c) / hm if hm > 0 else 0.0
            dw = 0.0
            if "hysteresis" in eff:
                dw = v / eff["hysteresis"]["x_y"] * (1 - abs(w) * (1.0 if v * w > 0 else 0.0))
            dy = 0.0
            if "backlash" in eff:
                b = eff["backlash"]["play"]
                if (s - yb >= b and v > 0) or (s - yb <= -b and v < 0):
                    dy = v
            dFa = (u_act(tt) - Fa) / tau if tau > 0 else 0.0
            if qc:
                Ft_tot = Fst - kt * (zu - r) - ct * (vu - rd)
                if lift:
                    Ft_tot = max(Ft_tot, 0.0)
                return [vs, F / ms, vu, (-F + Ft_tot - Fst) / mu, dw, dy, dFa, dR]
            return [vs, F / ms, 0.0, 0.0, dw, dy, dFa, dR]

        x0 = [0, 0, 0, 0, 0, 0, u_act(0.0), 0.0]
        sol = solve_ivp(rhs, (0, t[-1]), x0, t_eval=t, method="DOP853", rtol=1e-7, atol=1e-10, max_step=5.0 / fs)
        X = sol.y
        acc = np.array([rhs(tt, X[:, i]) for i, tt in enumerate(t)])
        if qc:
            r, rd = road(t), roadd(t)
            Ft = -kt * (X[2] - r) - ct * (X[3] - rd)
            if lift:
                Ft = np.maximum(Ft + Fst, 0.0) - Fst
            clean = {"body_acc": acc[:, 1], "wheel_acc": acc[:, 3], "susp_travel": X[0] - X[2], "body_pos": X[0],
                     "wheel_pos": X[2], "tire_force": Ft}
            ins = {"road": road(t)}
        else:
            clean = {"pos": X[0], "vel": X[1], "acc": acc[:, 1]}
            ins = {}
            if road_rms > 0:
                ins["base"] = road(t)
        if force_rms > 0:
            ins["force"] = force(t)
    outputs = outputs or list(clean)
    noisy = {kk: clean[kk] + noise * np.std(clean[kk]) * rng.standard_normal(len(t)) for kk in outputs}
    return {"time": t, **ins, **noisy, "_clean": {kk: clean[kk] for kk in outputs}}


HC_NOMINAL = {"sprung_mass": 500.0, "pitch_inertia": 1125.0, "a": 1.5, "b": 1.5, "unsprung_mass_front": 45.0,
              "unsprung_mass_rear": 45.0, "spring_stiffness_front": 17000.0, "spring_stiffness_rear": 17000.0,
              "damping_front": 1250.0, "damping_rear": 1250.0, "tire_stiffness_front": 100000.0,
              "tire_stiffness_rear": 100000.0, "tire_damping_front": 0.0, "tire_damping_rear": 0.0}
HC_OUTPUTS = [f"{n}_{e}" for e in ("front", "rear") for n in
              ("body_acc", "wheel_acc", "susp_travel", "body_pos", "wheel_pos", "tire_force")] + ["pitch", "pitch_rate"]


def simulate_truth_half(duration: float, fs: float, effects: dict, params: dict | None = None, seed: int = 0,
                        road_rms: float = 0.01, noise: float = 0.01, outputs: list[str] | None = None,
                        wheelbase_delay: float = 0.15, band=(0.3, 15.0)):
    """A synthetic half-car record (bounce z, pitch θ positive nose down, front wheel at x = +a, rear at −b).
    The rear road is the front road delayed by ``wheelbase_delay`` (a car driving at (a + b)/delay).  Every
    hidden effect acts at both corners with the same parameters (stateless effects and ``tire_liftoff``),
    unless its parameters say ``axle: front`` or ``axle: rear`` (then on that axle only).

    Written from the Lagrangian of the rigid body independently of the fast simulator: with the corner
    heights z_c = z − x_c·θ, the body equations are M·z̈ = Σ F_c and I·θ̈ = −Σ x_c·F_c.  A Maxwell damper
    (``maxwell_damper`` {compliance h}) puts each corner's damper c on a mount of compliance h: its force R obeys
    dR/dt = (v − R/c)/h (one state per corner) and replaces the damper's c·v."""
    bad = set(effects) - {"coulomb_friction", "quadratic_damping", "asymmetric_damping", "bump_stop",
                          "cubic_stiffness", "tire_liftoff", "maxwell_damper"}
    if bad:
        raise ValueError(f"half-car truth does not implement {sorted(bad)}")
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * fs))) / fs
    p = dict(HC_NOMINAL)
    p.update(params or {})
    road, roadd = random_signal(rng, duration, band[0], band[1], road_rms)
    eff = {k: v for k, v in effects.items() if k not in ("tire_liftoff", "maxwell_damper")}
    lift = "tire_liftoff" in effects
    mx = effects.get("maxwell_damper")
    M, I, a, b = p["sprung_mass"], p["pitch_inertia"], p["a"], p["b"]
    L = a + b
    corners = [(+a, "front", 0.0, b / L), (-b, "rear", wheelbase_delay, a / L)]

    def road_at(tt, d):
        return (float(road(tt - d)), float(roadd(tt - d))) if tt - d >= 0 else (float(road(0.0)), 0.0)

    def maxwell_at(e):
        return mx is not None and mx.get("axle", e) == e and mx["compliance"] > 0

    def parts(tt, X):
        z, vz, th, vth = X[:4]
        Fs, Ft, ss = [], [], []
        for j, (xc, e, d, share) in enumerate(corners):
            zu, vu = X[4 + 2 * j], X[5 + 2 * j]
            s = z - xc * th - zu
            v = vz - xc * vth - vu
            mine = {k: q for k, q in eff.items() if q.get("axle", e) == e}
            fd = X[8 + j] if maxwell_at(e) else p[f"damping_{e}"] * v
            F = -p[f"spring_stiffness_{e}"] * s - fd + _suspension_extra(mine, s, v, {})
            r, rd = road_at(tt, d)
            st = (M * share + p[f"unsprung_mass_{e}"]) * G
            ft = st - p[f"tire_stiffness_{e}"] * (zu - r) - p[f"tire_damping_{e}"] * (vu - rd)
            if lift:
                ft = max(ft, 0.0)
            Fs.append(F)
            Ft.append(ft - st)
            ss.append(s)
        return Fs, Ft, ss

    def rhs(tt, X):
        Fs, Ft, _ = parts(tt, X)
        out = [X[1], sum(Fs) / M, X[3], -sum(xc * F for (xc, *_), F in zip(corners, Fs)) / I]
        for j, (xc, e, d, share) in enumerate(corners):
            out += [X[5 + 2 * j], (-Fs[j] + Ft[j]) / p[f"unsprung_mass_{e}"]]
        for j, (xc, e, d, share) in enumerate(corners):  # the Maxwell dampers' forces
            v = X[1] - xc * X[3] - X[5 + 2 * j]
            out.append((v - X[8 + j] / p[f"damping_{e}"]) / mx["compliance"] if maxwell_at(e) else 0.0)
        return out

    sol = solve_ivp(rhs, (0, t[-1]), np.zeros(10), t_eval=t, method="DOP853", rtol=1e-7, atol=1e-10,
                    max_step=5.0 / fs)
    X = sol.y
    clean = {}
    D = np.array([rhs(tt, X[:, i]) for i, tt in enumerate(t)])
    T = np.array([parts(tt, X[:, i])[1] for i, tt in enumerate(t)])
    for j, (xc, e, d, share) in enumerate(corners):
        clean[f"body_acc_{e}"] = D[:, 1] - xc * D[:, 3]
        clean[f"wheel_acc_{e}"] = D[:, 5 + 2 * j]
        clean[f"body_pos_{e}"] = X[0] - xc * X[2]
        clean[f"wheel_pos_{e}"] = X[4 + 2 * j]
        clean[f"susp_travel_{e}"] = clean[f"body_pos_{e}"] - X[4 + 2 * j]
        clean[f"tire_force_{e}"] = T[:, j]
    clean["pitch"], clean["pitch_rate"] = X[2], X[3]
    ins = {"road_front": np.array([road_at(tt, 0.0)[0] for tt in t]),
           "road_rear": np.array([road_at(tt, wheelbase_delay)[0] for tt in t])}
    outputs = outputs or HC_OUTPUTS
    noisy = {kk: clean[kk] + noise * np.std(clean[kk]) * rng.standard_normal(len(t)) for kk in outputs}
    return {"time": t, **ins, **noisy, "_clean": {kk: clean[kk] for kk in outputs}}


# ------------------------------------------------------------------------------------------------------
# full car: the project's own plant and component laws (``suspension-sim run``), not a private model
# ------------------------------------------------------------------------------------------------------
FC_CORNERS = ("fl", "fr", "rl", "rr")
FC_NOMINAL = {"sprung_mass": 1413.0, "roll_inertia": 500.0, "pitch_inertia": 2100.0, "unsprung_mass_front": 40.0,
              "unsprung_mass_rear": 35.0, "spring_stiffness_front": 20000.0, "spring_stiffness_rear": 19500.0,
              "damping_front": 1700.0, "damping_rear": 1450.0, "tire_stiffness_front": 200000.0,
              "tire_stiffness_rear": 200000.0, "tire_damping_front": 0.0, "tire_damping_rear": 0.0,
              "arb_front": 25000.0, "arb_rear": 10000.0}
FC_OUTPUTS = ([f"body_acc_{c}" for c in FC_CORNERS] + [f"susp_travel_{c}" for c in FC_CORNERS]
              + [f"wheel_acc_{c}" for c in FC_CORNERS] + ["pitch_rate", "roll_rate"])


def _full_car_run(duration, fs, effects, p, seed, road_class, speed, dt, variations=()):
    """One ``suspension-sim run`` of the full car (``models/full_car.xml``) on an ISO 8608 road with
    independent left and right tracks; returns the log (a DataFrame at ``fs``)."""
    from ..config import parse_scenario
    from ..simulation import Simulation

    eff = []
    for name, q in effects.items():
        q = dict(q)
        corners = q.pop("corners", "all")
        eff.append({"type": name, "corners": corners, "params": q})
    sc = parse_scenario({
        "name": "truth_full_car",
        "vehicle": {"model": "full_car", "params": dict(p), "effects": eff, "variations": list(variations)},
        "road": {"type": "iso8608", "params": {"road_class": road_class}, "speed": float(speed),
                 "tracks": "independent", "seed": int(seed)},
        "controller": {"type": "passive"},
        "sim": {"duration": float(duration), "dt": float(dt), "control_dt": 1.0 / fs, "log_dt": 1.0 / fs,
                "seed": int(seed)},
        "outputs": {"timeseries": True, "plots": False}})
    return Simulation([sc]).run()[0].ts


def simulate_truth_full(duration: float, fs: float, effects: dict, params: dict | None = None, seed: int = 0,
                        road_class: str = "C", speed: float = 15.0, noise: float = 0.02,
                        outputs: list[str] | None = None, offsets: dict | None = None, sag: bool = False,
                        substeps: int = 8):
    """A synthetic full-car record from the project's own plant and component laws: the full car of
    ``models/full_car.xml`` with the hidden ``effects`` (the registered effects, on the corners their
    ``corners`` entry names, default all), run by the project's simulation at a physics step of
    1/(``substeps``·fs) (the search runs at ≥ 0.5 ms), on an ISO 8608 road of ``road_class`` with
    independent left and right tracks at ``speed`` (each rear wheel meets its track a wheelbase later, so
    bounce, pitch, roll and warp are all excited).  Nothing here is a private law: one law, one place.

    Sensors: the body accelerations above the four corners, the four travels, the four wheel accelerations,
    and the pitch and roll rates (:data:`FC_OUTPUTS`); the inputs are the road under each wheel
    (``road_fl`` …).  Noise: white, std = ``noise`` × the channel's std (as :func:`simulate_truth`);
    ``offsets``: {channel: sensor offset} added to the noisy channel.  A changed mass in ``params`` moves
    the equilibrium (the car is re-levelled, like a scenario); ``sag=True`` shows it instead at position
    sensors zeroed at the nominal ride height: the static deflection from the nominal to the changed car
    (the nominal car loaded with the change on a flat road until it settles) is added to the travels,
    pitch and roll.  Returns the dict of :func:`simulate_truth` (``_clean``: noise-free outputs)."""
    rng = np.random.default_rng(seed + 1000)
    p = dict(FC_NOMINAL)
    p.update(params or {})
    dt = 1.0 / (fs * substeps)
    ts = _full_car_run(duration, fs, effects, p, seed, road_class, speed, dt)
    n = int(round(duration * fs))
    ts = ts.iloc[:n]
    t = ts["t"].to_numpy() - float(ts["t"].iloc[0])
    from ..vehicles.full_car import FullCarParams, corner_geometry

    geo = corner_geometry(FullCarParams(**p))
    col = lambda k: ts[k].to_numpy().copy()  # noqa: E731
    clean = {}
    for c in FC_CORNERS:
        x, y = geo[c]
        # the body above the corner: z − x·θ + y·φ (pitch nose down, roll right side down)
        clean[f"body_acc_{c}"] = col("body_acc") - x * col("pitch_acc") + y * col("roll_acc")
        clean[f"body_pos_{c}"] = col("body_z") - x * col("pitch") + y * col("roll")
        clean[f"susp_travel_{c}"] = col(f"travel_{c}")
        clean[f"wheel_acc_{c}"] = col(f"wheel_acc_{c}")
        clean[f"wheel_pos_{c}"] = col(f"wheel_z_{c}")
        clean[f"tire_force_{c}"] = col(f"tire_force_{c}")
    for j in ("pitch", "roll"):
        clean[j], clean[f"{j}_rate"], clean[f"{j}_acc"] = col(j), col(f"{j}_rate"), col(f"{j}_acc")
    if sag:
        changed = {k: v for k, v in (params or {}).items() if k in ("sprung_mass", "unsprung_mass_front",
                                                                    "unsprung_mass_rear")}
        if changed:
            st = _static_sag(changed, fs, dt)
            for k, v in st.items():
                if k in clean:
                    clean[k] = clean[k] + v
            for c in FC_CORNERS:
                x, y = geo[c]
                clean[f"body_pos_{c}"] = clean[f"body_pos_{c}"] + st["body_z"] - x * st["pitch"] + y * st["roll"]
    ins = {f"road_{c}": col(f"road_{c}") for c in FC_CORNERS}
    outputs = outputs or FC_OUTPUTS
    noisy = {k: clean[k] + noise * np.std(clean[k]) * rng.standard_normal(len(t)) + (offsets or {}).get(k, 0.0)
             for k in outputs}
    return {"time": t, **ins, **noisy, "_clean": {k: clean[k] for k in outputs}}


def _static_sag(changed: dict, fs: float, dt: float) -> dict:
    """Static deflection of the nominal full car when its masses become ``changed`` without re-levelling (a
    load added as a time-varying parameter, as the project shows sag): the state after it settles on a flat
    road (20 s; the slowest mode, ~1 Hz at ζ ≈ 0.3, has then decayed by e⁻³⁸)."""
    from ..config import parse_scenario
    from ..simulation import Simulation

    var = [{"param": k, "kind": "step", "mode": "set", "times": [0.0], "values": [float(v)]}
           for k, v in changed.items()]
    sc = parse_scenario({"name": "truth_full_car_sag",
                         "vehicle": {"model": "full_car", "params": dict(FC_NOMINAL), "variations": var},
                         "road": {"type": "flat"}, "controller": {"type": "passive"},
                         "sim": {"duration": 20.0, "dt": dt, "control_dt": 1.0 / fs, "log_dt": 1.0 / fs},
                         "outputs": {"timeseries": True, "plots": False}})
    ts = Simulation([sc]).run()[0].ts
    last = ts.iloc[-1]
    out = {j: float(last[j]) for j in ("body_z", "pitch", "roll")}
    for c in FC_CORNERS:
        out[f"susp_travel_{c}"] = float(last[f"travel_{c}"])
        out[f"wheel_pos_{c}"] = float(last[f"wheel_z_{c}"])
    return out
