"""An independent half-car truth model for blind tests of `suspension-sim diagnose` (pitch plane).

Written from the equations for the blind battery (benchmarks/blind_battery.py), beside the quarter-car truth
(benchmarks/blind_truth.py, whose roads, input tabulation and sensor noise it imports); it imports nothing from
``suspension_sim`` (not its vehicle, effects, kernels, statics or ``diagnose/truth.py``).  Integrated by scipy
``solve_ivp`` (DOP853, rtol 1e-9) with

- a rigid body of mass M and pitch inertia I about its c.g. (heave z of the c.g., pitch θ positive nose down),
  a front axle at x = +a and a rear axle at x = −b from the c.g., one wheel per axle (mass m_u), small angles:
  the body at an axle is at z − x·θ, so M·z̈ = ΣF_s − M·g and I·θ̈ = −Σ x·F_s (gravity acts at the c.g.);
- absolute coordinates from the *nominal* static equilibrium: each spring carries its share of the nominal
  sprung weight at zero travel (M·g·b/L at the front, M·g·a/L at the rear), each tyre that share plus its
  wheel's weight, so a heavier car sags and a c.g. moved rearwards (a loaded boot: a point mass behind the
  c.g., which moves the c.g. and adds its own pitch inertia about the new c.g.) sits nose up;
- per axle: a linear spring and damper, an optional cubic spring term about the nominal ride height, end stops
  at fixed gaps from it (per side), Coulomb friction as a sharp tanh (v_eps 1 mm/s by default, as the quarter
  car's), and a linear tyre;
- the rear road is the front road delayed by the wheelbase over the speed (L/V), both measured;
- sensors: body accelerometers above the two axles, suspension travel front and rear (zeroed at the nominal
  ride height), wheel accelerometers, a pitch-rate gyro; the noise of blind_truth (white, pink, brown).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

import blind_truth as bt

GRAV = bt.GRAV
AXLES = ("front", "rear")

# half cars (one wheel per axle; kg, kg·m², m, N/m, N·s/m): a front-heavy sedan (body modes 1.2 / 1.45 Hz), an SUV
# with a long wheelbase and a van whose rear axle carries most of the body
HALF_VEHICLES = {
    "hsedan": dict(sprung_mass=690.0, pitch_inertia=1050.0, a=1.15, b=1.55,
                   unsprung_mass_front=46.0, unsprung_mass_rear=41.0,
                   spring_stiffness_front=22500.0, spring_stiffness_rear=24000.0,
                   damping_front=1750.0, damping_rear=1600.0,
                   tire_stiffness_front=230000.0, tire_stiffness_rear=220000.0,
                   tire_damping_front=0.0, tire_damping_rear=0.0),
    "hsuv": dict(sprung_mass=1010.0, pitch_inertia=1820.0, a=1.30, b=1.55,
                 unsprung_mass_front=68.0, unsprung_mass_rear=64.0,
                 spring_stiffness_front=36000.0, spring_stiffness_rear=33000.0,
                 damping_front=2950.0, damping_rear=2700.0,
                 tire_stiffness_front=320000.0, tire_stiffness_rear=310000.0,
                 tire_damping_front=0.0, tire_damping_rear=0.0),
    "hvan": dict(sprung_mass=1150.0, pitch_inertia=2600.0, a=1.75, b=1.45,
                 unsprung_mass_front=70.0, unsprung_mass_rear=82.0,
                 spring_stiffness_front=34000.0, spring_stiffness_rear=52000.0,
                 damping_front=2900.0, damping_rear=3500.0,
                 tire_stiffness_front=330000.0, tire_stiffness_rear=420000.0,
                 tire_damping_front=0.0, tire_damping_rear=0.0),
}
OUTPUTS = ["body_acc_front", "body_acc_rear", "susp_travel_front", "susp_travel_rear", "wheel_acc_front",
           "wheel_acc_rear", "pitch_rate"]


class Delayed:
    """An input seen ``d`` s later (the rear wheel on the front wheel's road): x(t − d), zero before the start."""

    def __init__(self, src, d):
        self.src, self.d = src, d

    def __call__(self, t):
        return self.src(t - self.d) if t > self.d else (0.0, 0.0)

    def both(self, t):
        t = np.asarray(t, float)
        x, xd = self.src.both(np.maximum(t - self.d, 0.0))
        m = t > self.d
        return np.where(m, x, 0.0), np.where(m, xd, 0.0)

    def sample(self, t):
        return self.both(t)[0]


def loaded(vehicle: dict, load: float, x_load: float) -> dict:
    """The car with a point load ``load`` kg at ``x_load`` m from the nominal c.g. (negative: behind it, the boot):
    the sprung mass, the c.g. moved to x_load·load/M′ (a and b change with the wheelbase kept) and the pitch
    inertia about the new c.g. (parallel axes)."""
    M, I, a, b = (vehicle[k] for k in ("sprung_mass", "pitch_inertia", "a", "b"))
    M2 = M + load
    dx = load * x_load / M2  # the c.g. moves this far forwards (negative: rearwards)
    I2 = I + M * dx ** 2 + load * (x_load - dx) ** 2
    return {**vehicle, "sprung_mass": M2, "pitch_inertia": I2, "a": a - dx, "b": b + dx}


def simulate(vehicle: dict, hidden: dict, road, speed: float, duration: float, fs: float):
    """Integrate the half car; returns the clean signals at fs (time, road_front, road_rear and OUTPUTS) and
    bookkeeping.

    ``vehicle``: the nominal parameters (what the user states).  ``hidden``: the truth's deviations, each per
    axle with ``axle`` "front", "rear" or "both" (default): ``load`` {mass, x} (a point load at x m from the
    nominal c.g.: :func:`loaded`), ``cubic`` {k3}, ``stops`` {gap_c, gap_e (None = no stop), k, c},
    ``coulomb`` {force, v_eps}.  ``road``: the front wheel's road (blind_truth input); the rear wheel sees it
    L/speed later."""
    V = vehicle
    T = loaded(V, hidden["load"]["mass"], hidden["load"]["x"]) if hidden.get("load") else V
    M0, a0, b0 = V["sprung_mass"], V["a"], V["b"]
    L = a0 + b0
    M, I, a, b = T["sprung_mass"], T["pitch_inertia"], T["a"], T["b"]
    delay = L / speed
    road_r_src = Delayed(road, delay)
    rf, rr = bt.Tabulated(road, duration), bt.Tabulated(road_r_src, duration)
    t_eval = np.arange(int(round(duration * fs))) / fs
    x_ax = {"front": a, "rear": -b}  # the true axle positions from the true c.g.
    # nominal static loads: each spring's preload at zero travel, each tyre's at the nominal equilibrium
    Fs0 = {"front": M0 * GRAV * b0 / L, "rear": M0 * GRAV * a0 / L}
    Ft0 = {e: Fs0[e] + V[f"unsprung_mass_{e}"] * GRAV for e in AXLES}

    def on(key, e):
        h = hidden.get(key)
        return h if h is not None and h.get("axle", "both") in ("both", e) else None

    laws = {e: dict(k=V[f"spring_stiffness_{e}"], c=V[f"damping_{e}"], kt=V[f"tire_stiffness_{e}"],
                    ct=V[f"tire_damping_{e}"], mu=V[f"unsprung_mass_{e}"], cubic=on("cubic", e),
                    stops=on("stops", e), coulomb=on("coulomb", e)) for e in AXLES}

    def susp(e, s, v):
        """The axle's suspension force on the body (N, + up), its preload included."""
        q = laws[e]
        F = Fs0[e] - q["k"] * s - q["c"] * v
        if q["cubic"]:
            F -= q["cubic"]["k3"] * s ** 3
        st = q["stops"]
        if st:
            if st["gap_c"] is not None and s < -st["gap_c"]:
                F += max(0.0, st["k"] * (-st["gap_c"] - s) - st.get("c", 0.0) * v)
            if st.get("gap_e") is not None and s > st["gap_e"]:
                F += min(0.0, -st["k"] * (s - st["gap_e"]) - st.get("c", 0.0) * v)
        cf = q["coulomb"]
        if cf:
            F -= cf["force"] * math.tanh(v / cf.get("v_eps", 0.001))
        return F

    def rhs(t, X):
        z, vz, th, vth, zf, vf, zr, vr = X
        roads = {"front": rf(t), "rear": rr(t)}
        wheel = {"front": (zf, vf), "rear": (zr, vr)}
        Fs, acc_u = {}, {}
        for e in AXLES:
            x = x_ax[e]
            zu, vu = wheel[e]
            s, v = z - x * th - zu, vz - x * vth - vu
            Fs[e] = susp(e, s, v)
            r, rd = roads[e]
            Ft = Ft0[e] - laws[e]["kt"] * (zu - r) - laws[e]["ct"] * (vu - rd)
            acc_u[e] = (Ft - Fs[e]) / laws[e]["mu"] - GRAV
        zdd = (Fs["front"] + Fs["rear"]) / M - GRAV
        thdd = -(x_ax["front"] * Fs["front"] + x_ax["rear"] * Fs["rear"]) / I
        return [vz, zdd, vth, thdd, vf, acc_u["front"], vr, acc_u["rear"]]

    X0 = np.zeros(8)
    if T is not V:  # a loaded car has settled before the record starts: the static equilibrium of the true car
        def static(q):
            z, th, zf, zr = q
            d = rhs(0.0, [z, 0.0, th, 0.0, zf, 0.0, zr, 0.0])
            return [d[1], d[3], d[5], d[7]]
        q = fsolve(static, np.zeros(4))
        if np.max(np.abs(static(q))) > 1e-6:  # m/s², rad/s²
            raise RuntimeError(f"no static equilibrium found (residual {np.max(np.abs(static(q))):.3g})")
        X0[[0, 2, 4, 6]] = q
    sol = solve_ivp(rhs, (0, t_eval[-1]), X0, t_eval=t_eval, method="DOP853", rtol=1e-9, atol=1e-12,
                    max_step=2.0 / fs)
    if sol.status != 0:
        raise RuntimeError(sol.message)
    X = sol.y
    D = np.array([rhs(t, X[:, j]) for j, t in enumerate(t_eval)])
    out = {"time": t_eval, "road_front": road.sample(t_eval), "road_rear": road_r_src.sample(t_eval)}
    for j, e in enumerate(AXLES):
        x = x_ax[e]
        out[f"body_acc_{e}"] = D[:, 1] - x * D[:, 3]
        out[f"susp_travel_{e}"] = X[0] - x * X[2] - X[4 + 2 * j]
        out[f"wheel_acc_{e}"] = D[:, 5 + 2 * j]
    out["pitch_rate"] = X[3]
    out["travel_static"] = {e: float(X0[0] - x_ax[e] * X0[2] - X0[4 + 2 * j]) for j, e in enumerate(AXLES)}
    out["true_vehicle"] = T
    out["delay"] = delay
    if hidden.get("stops"):  # the share of samples with a stop engaged on either axle
        eng = [bt.stop_engaged(out[f"susp_travel_{e}"], hidden["stops"]) for e in AXLES if on("stops", e)]
        out["stop_share"] = float(np.mean(np.logical_or.reduce(eng)))
    return out
