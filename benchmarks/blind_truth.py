"""An independent quarter-car truth model for blind tests of `suspension-sim diagnose`.

Written from scratch for the blind battery (benchmarks/blind_battery.py): it imports nothing from
``suspension_sim`` (no effect, kernel, vehicle or truth.py law) and shares none of its conventions beyond the
data-file format.  Integrated by scipy ``solve_ivp`` (DOP853, rtol 1e-9) with

- the car in absolute coordinates from the *nominal* static equilibrium (the spring carries the nominal
  sprung weight at zero travel, the tyre the nominal corner weight), so a changed sprung mass sags;
- a linear spring and damper (or separate total compression / rebound damping rates), an optional cubic
  (progressive) spring term about the nominal ride height, end stops at fixed geometric gaps from the
  nominal ride height (per side, optionally damped), Coulomb friction as a sharp tanh (v_eps 1 mm/s by default; an exact
  stick-slip version by events was tried and was too slow to integrate here), an actuator force through a first-order lag,
  and a unilateral tyre (the total tyre force never pulls: lift-off); two laws *beyond* the diagnose library:
  a Dahl friction element (dF/dt = σ·v·(1 − F/F_c·sgn v): a hysteretic damper with a pre-sliding stiffness
  σ) and a Maxwell damper (the damper in series with a compliant top-mount bushing, dF/dt = k_b·(v − F/c):
  damping that fades with frequency; both were written beyond the library, the Maxwell damper has since joined
  it), and a digressive damper (a blow-off valve: the rate drops above a knee rate, per side);
- inputs: an ISO 8608 random road of a given class at a speed (a sum of sines in spatial frequency with
  the class's displacement PSD Gd(n0)·(n/n0)^-2), discrete bumps and potholes, kerb steps (level changes
  that stay), a swept-sine road (a four-post rig), a sine dwell, sums of these, and a measured actuator force
  command (random or swept sine);
- sampling: any rate, and sample instants that jitter about their nominal stamps (``times``);
- sensors: white, pink (1/f) or brown (1/f²) noise, static biases on the accelerometers, and a travel
  sensor zeroed at the nominal ride height (or anywhere: a static offset).

A record is a CSV (``time``, ``road``, optional ``force``, and the measured outputs) plus the model file
(MODEL.yaml) a user would supply: the nominal vehicle's parameters.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

GRAV = 9.81

# corner vehicles, from a small city car to a truck axle end (kg, N/m, N·s/m)
VEHICLES = {
    "city": dict(sprung_mass=215.0, unsprung_mass=31.0, spring_stiffness=17500.0, damping=1250.0,
                 tire_stiffness=165000.0, tire_damping=0.0),
    "sedan": dict(sprung_mass=385.0, unsprung_mass=46.0, spring_stiffness=25500.0, damping=1850.0,
                  tire_stiffness=235000.0, tire_damping=0.0),
    "sports": dict(sprung_mass=305.0, unsprung_mass=38.0, spring_stiffness=43000.0, damping=2900.0,
                   tire_stiffness=290000.0, tire_damping=0.0),
    "suv": dict(sprung_mass=560.0, unsprung_mass=68.0, spring_stiffness=36000.0, damping=2950.0,
                tire_stiffness=320000.0, tire_damping=150.0),
    "van": dict(sprung_mass=810.0, unsprung_mass=82.0, spring_stiffness=62000.0, damping=4300.0,
                tire_stiffness=450000.0, tire_damping=0.0),
    "truck": dict(sprung_mass=3150.0, unsprung_mass=430.0, spring_stiffness=410000.0, damping=19500.0,
                  tire_stiffness=1.75e6, tire_damping=0.0),
    # unusual corners: a very soft limousine (body mode 0.75 Hz), a very stiff race car (2.9 Hz, stiff tyre), and
    # a sedan with in-wheel motors (unsprung mass a quarter of the sprung: the wheel mode near 9 Hz)
    "limo": dict(sprung_mass=520.0, unsprung_mass=55.0, spring_stiffness=11800.0, damping=1500.0,
                 tire_stiffness=250000.0, tire_damping=0.0),
    "racer": dict(sprung_mass=230.0, unsprung_mass=30.0, spring_stiffness=80000.0, damping=4200.0,
                  tire_stiffness=400000.0, tire_damping=0.0),
    "inwheel": dict(sprung_mass=385.0, unsprung_mass=96.0, spring_stiffness=25500.0, damping=2100.0,
                    tire_stiffness=235000.0, tire_damping=0.0),
}
ISO_GD = {"A": 16e-6, "B": 64e-6, "C": 256e-6, "D": 1024e-6, "E": 4096e-6}  # Gd(n0 = 0.1 c/m), m³


# ------------------------------------------------------------------------------------------------------
# inputs: smooth functions of time (value and derivative), so the integrator sees no tabulation kinks
# ------------------------------------------------------------------------------------------------------
class SineSum:
    """x(t) = env(t)·Σ a_i sin(w_i t + φ_i)  (env: a 0.5 s cosine fade-in)."""

    def __init__(self, a, w, ph, fade=0.5):
        self.a, self.w, self.ph, self.fade = (np.asarray(a, float), np.asarray(w, float), np.asarray(ph, float),
                                             fade)

    def _env(self, t):
        if t <= 0:
            return 0.0, 0.0
        if t >= self.fade:
            return 1.0, 0.0
        u = math.pi * t / self.fade
        return 0.5 - 0.5 * math.cos(u), 0.5 * math.sin(u) * math.pi / self.fade

    def __call__(self, t):
        arg = self.w * t + self.ph
        s = float(np.dot(self.a, np.sin(arg)))
        d = float(np.dot(self.a * self.w, np.cos(arg)))
        e, de = self._env(t)
        return e * s, e * d + de * s

    def both(self, t):
        """(x, ẋ) at an array of times."""
        t = np.asarray(t, float)
        x, xd = np.zeros_like(t), np.zeros_like(t)
        for j in range(0, len(self.a), 50):
            arg = np.outer(t, self.w[j:j + 50]) + self.ph[j:j + 50]
            x += np.sin(arg) @ self.a[j:j + 50]
            xd += np.cos(arg) @ (self.a[j:j + 50] * self.w[j:j + 50])
        u = np.clip(t / self.fade, 0.0, 1.0)
        e = 0.5 - 0.5 * np.cos(np.pi * u)
        de = np.where((t > 0) & (t < self.fade), 0.5 * np.sin(np.pi * u) * np.pi / self.fade, 0.0)
        return e * x, e * xd + de * x

    def sample(self, t):
        return self.both(t)[0]


def iso_road(rng, road_class: str, speed: float, n_lines: int = 300, n_max: float = 4.0) -> SineSum:
    """ISO 8608 road of a class (A–E, the class's geometric mean) driven at ``speed`` m/s: spatial frequencies
    n (cycles/m) from max(0.011, 0.3 Hz/speed) to ``n_max``, Gd(n) = Gd(n0)·(n/n0)^-2, random phases."""
    n_min = max(0.011, 0.3 / speed)
    edges = np.geomspace(n_min, n_max, n_lines + 1)
    n = np.sqrt(edges[1:] * edges[:-1])
    dn = np.diff(edges)
    gd = ISO_GD[road_class] * (n / 0.1) ** -2
    a = np.sqrt(2 * gd * dn)
    return SineSum(a, 2 * np.pi * n * speed, rng.uniform(0, 2 * np.pi, n_lines))


class Bumps:
    """Discrete bumps (+) and potholes (−) of height h and length L (m) at positions x0 (m), driven at
    ``speed``: h·sin²(π·(x − x0)/L) over each (C¹), plus an optional ISO background road."""

    def __init__(self, rng, duration, speed, h_range=(0.02, 0.05), L_range=(0.4, 2.5), gap_range=(8.0, 25.0),
                 pothole_share=0.3, background: SineSum | None = None):
        self.speed, self.bg = speed, background
        xs, hs, Ls = [], [], []
        x = speed * 0.8
        while x < speed * (duration - 0.3):
            L = rng.uniform(*L_range)
            h = rng.uniform(*h_range) * (-1 if rng.random() < pothole_share else 1)
            xs.append(x), hs.append(h), Ls.append(L)
            x += L + rng.uniform(*gap_range)
        self.x0, self.h, self.L = np.array(xs), np.array(hs), np.array(Ls)

    def __call__(self, t):
        x = self.speed * t
        r, rd = (0.0, 0.0) if self.bg is None else self.bg(t)
        i = np.searchsorted(self.x0, x) - 1
        if i >= 0 and x < self.x0[i] + self.L[i]:
            u = math.pi * (x - self.x0[i]) / self.L[i]
            r += self.h[i] * math.sin(u) ** 2
            rd += self.h[i] * 2 * math.sin(u) * math.cos(u) * math.pi / self.L[i] * self.speed
        return r, rd

    def both(self, t):
        t = np.asarray(t, float)
        x = self.speed * t
        r, rd = (np.zeros_like(t), np.zeros_like(t)) if self.bg is None else self.bg.both(t)
        for x0, h, L in zip(self.x0, self.h, self.L):
            m = (x >= x0) & (x < x0 + L)
            u = np.pi * (x[m] - x0) / L
            r[m] += h * np.sin(u) ** 2
            rd[m] += h * 2 * np.sin(u) * np.cos(u) * np.pi / L * self.speed
        return r, rd

    def sample(self, t):
        return self.both(t)[0]


class Steps:
    """Kerb steps: the road level changes by h (m) over a length L (m) at positions x0 and stays there
    (h·sin²(π/2·(x − x0)/L) over the ramp: C¹), driven at ``speed``; ups and downs alternate about zero."""

    def __init__(self, rng, duration, speed, h_range=(0.02, 0.04), L_range=(0.15, 0.4), gap_range=(6.0, 15.0)):
        self.speed = speed
        xs, hs, Ls = [], [], []
        x, level = speed * 0.8, 0.0
        while x < speed * (duration - 0.3):
            L = rng.uniform(*L_range)
            h = rng.uniform(*h_range) * (-1.0 if level > 0 else 1.0)
            level += h
            xs.append(x), hs.append(h), Ls.append(L)
            x += L + rng.uniform(*gap_range)
        self.x0, self.h, self.L = np.array(xs), np.array(hs), np.array(Ls)

    def __call__(self, t):
        r, rd = self.both(np.array([t]))
        return float(r[0]), float(rd[0])

    def both(self, t):
        t = np.asarray(t, float)
        x = self.speed * t
        r, rd = np.zeros_like(t), np.zeros_like(t)
        for x0, h, L in zip(self.x0, self.h, self.L):
            u = np.clip((x - x0) / L, 0.0, 1.0)
            r += h * np.sin(0.5 * np.pi * u) ** 2
            m = (x > x0) & (x < x0 + L)
            rd[m] += h * np.sin(np.pi * u[m]) * 0.5 * np.pi / L * self.speed
        return r, rd

    def sample(self, t):
        return self.both(t)[0]


class Sum:
    """The sum of several inputs."""

    def __init__(self, *parts):
        self.parts = parts

    def __call__(self, t):
        v = [p(t) for p in self.parts]
        return sum(a for a, _ in v), sum(b for _, b in v)

    def both(self, t):
        v = [p.both(t) for p in self.parts]
        return sum(a for a, _ in v), sum(b for _, b in v)

    def sample(self, t):
        return self.both(t)[0]


class Sweep:
    """A swept sine from f0 to f1 Hz over the record (log sweep), amplitude a·(f0/f)^p (constant
    displacement for p = 0; a shaker rig keeps velocity or acceleration bounded with p > 0)."""

    def __init__(self, f0, f1, duration, amp, p=0.0):
        self.f0, self.f1, self.T, self.amp, self.p = f0, f1, duration, amp, p
        self.K = math.log(f1 / f0) / duration

    def __call__(self, t):
        if t <= 0:
            return 0.0, 0.0
        f = self.f0 * math.exp(self.K * t)
        ph = 2 * math.pi * self.f0 * (math.exp(self.K * t) - 1) / self.K
        A = self.amp * (self.f0 / f) ** self.p
        dA = -self.p * self.K * A
        fade = min(1.0, t / 0.5)
        dfade = 2.0 if t < 0.5 else 0.0
        return fade * A * math.sin(ph), fade * (dA * math.sin(ph) + A * 2 * math.pi * f * math.cos(ph)) + \
            dfade * A * math.sin(ph)

    def both(self, t):
        out = np.array([self(tt) for tt in np.asarray(t, float)])
        return out[:, 0], out[:, 1]

    def sample(self, t):
        return self.both(t)[0]


class Zero:
    def __call__(self, t):
        return 0.0, 0.0

    def both(self, t):
        return np.zeros(len(t)), np.zeros(len(t))

    def sample(self, t):
        return np.zeros(len(t))


class Tabulated:
    """A smooth input tabulated with its derivative every ``h`` s and evaluated by cubic Hermite
    interpolation (C¹, fourth-order accurate): a fast scalar call for the integrator."""

    def __init__(self, src, duration, h=5e-5):
        self.src, self.h = src, h
        tg = np.arange(0.0, duration + 0.05, h)
        self.y, self.dy = (np.ascontiguousarray(a) for a in src.both(tg))
        self.n = len(tg)

    def __call__(self, t):
        u = t / self.h
        i = min(max(int(u), 0), self.n - 2)
        f = u - i
        if f < 0.0:
            f = 0.0
        y0, y1, d0, d1 = self.y[i], self.y[i + 1], self.dy[i] * self.h, self.dy[i + 1] * self.h
        f2, f3 = f * f, f * f * f
        val = (2 * f3 - 3 * f2 + 1) * y0 + (f3 - 2 * f2 + f) * d0 + (-2 * f3 + 3 * f2) * y1 + (f3 - f2) * d1
        der = ((6 * f2 - 6 * f) * y0 + (3 * f2 - 4 * f + 1) * d0 + (-6 * f2 + 6 * f) * y1 + (3 * f2 - 2 * f) * d1) / self.h
        return val, der

    def sample(self, t):
        return self.src.sample(t)


# ------------------------------------------------------------------------------------------------------
# the car
# ------------------------------------------------------------------------------------------------------
def simulate(vehicle: dict, hidden: dict, road, force, duration: float, fs: float, times=None):
    """Integrate the car; returns dict of clean signals sampled at fs (time, road, force, body_acc, wheel_acc,
    susp_travel, tire_force total) and bookkeeping (stick share, lift share, stop share).

    ``vehicle``: the nominal parameters (what the user states); ``hidden``: the truth's deviations:
    ``mass`` (true sprung mass, kg), ``asym`` {c_comp, c_reb} (total damping rates replacing ``damping``),
    ``cubic`` {k3} (N/m³ about the nominal ride height), ``stops`` {gap_c, gap_e (None = no stop), k, c},
    ``coulomb`` {force, v_eps (default 1 mm/s)}, ``lag`` {tau} (s), ``liftoff`` (bool),
    ``quad`` {c_v} (N·s²/m²), ``digressive`` {v_k, ratio, optional v_k_reb, ratio_reb} (a damper with a blow-off
    valve: the rate ``damping`` up to the knee rate v_k, ``ratio`` × it beyond; in rebound the ``_reb`` values
    when given, else the same), ``dahl`` {force, x_y} (a Dahl friction element of level F_c and pre-sliding
    displacement x_y = F_c/σ, beside the linear damper), ``maxwell`` {k_b} (the linear damper in series with a
    bushing of stiffness k_b).  ``times``: the instants actually sampled (default k/fs; jittered sampling)."""
    road_src, force_src = road, force
    road, force = Tabulated(road, duration), Tabulated(force, duration)
    t_eval = np.arange(int(round(duration * fs))) / fs if times is None else np.asarray(times, float)
    V = vehicle
    ms_nom, mu = V["sprung_mass"], V["unsprung_mass"]
    ms = hidden.get("mass", ms_nom)
    k, c, kt, ct = V["spring_stiffness"], V["damping"], V["tire_stiffness"], V["tire_damping"]
    F_s0 = ms_nom * GRAV  # the spring's preload at zero travel (nominal ride height)
    F_t0 = (ms_nom + mu) * GRAV  # the tyre's load at the nominal equilibrium
    asym = hidden.get("asym")
    k3 = hidden.get("cubic", {}).get("k3", 0.0)
    stops = hidden.get("stops")
    cq = hidden.get("quad", {}).get("c_v", 0.0)
    cf = hidden.get("coulomb")
    Fc = cf["force"] if cf else 0.0
    tanh_law = bool(cf)
    veps = cf.get("v_eps", 0.001) if cf else 1.0
    tau = hidden.get("lag", {}).get("tau", 0.0)
    lift = bool(hidden.get("liftoff"))
    dahl, mx = hidden.get("dahl"), hidden.get("maxwell")
    dig = hidden.get("digressive")

    def susp(s, v, Fa, z=0.0):
        """Suspension force on the body without friction (N, + up), incl. the preload; ``z`` the internal
        element's force (Dahl friction or the Maxwell damper's)."""
        if mx:
            fd = z
        elif asym:
            fd = (asym["c_reb"] if v > 0 else asym["c_comp"]) * v
        elif dig:  # each side its own knee and ratio (``v_k_reb``, ``ratio_reb``; default: the same as ``v_k``, ``ratio``)
            av = abs(v)
            vk, r = (dig.get("v_k_reb", dig["v_k"]), dig.get("ratio_reb", dig["ratio"])) if v > 0 else (dig["v_k"], dig["ratio"])
            fd = math.copysign(c * av if av <= vk else c * vk + r * c * (av - vk), v)
        else:
            fd = c * v
        F = F_s0 - k * s - fd - k3 * s ** 3 - cq * v * abs(v) + Fa
        if dahl:
            F -= z
        if stops:
            g_c, g_e, ks, cs = stops["gap_c"], stops.get("gap_e"), stops["k"], stops.get("c", 0.0)
            if g_c is not None and s < -g_c:
                F += max(0.0, ks * (-g_c - s) - cs * v)
            if g_e is not None and s > g_e:
                F += min(0.0, -ks * (s - g_e) - cs * v)
        return F

    def tyre(zu, vu, t):
        r, rd = road(t)
        Ft = F_t0 - kt * (zu - r) - ct * (vu - rd)
        return max(Ft, 0.0) if lift else Ft

    def u_cmd(t):
        return force(t)[0]

    def parts(t, x):
        zs, vs, zu, vu, Fa, z = x
        s, v = zs - zu, vs - vu
        Fact = Fa if tau > 0 else u_cmd(t)
        return susp(s, v, Fact, z), tyre(zu, vu, t), s, v

    def dz(x):
        v = x[1] - x[3]
        if dahl:
            return dahl["force"] / dahl["x_y"] * v * (1.0 - x[5] / dahl["force"] * math.copysign(1.0, v))
        if mx:
            return mx["k_b"] * (v - x[5] / c)
        return 0.0

    def accel(Fsus, Ff, Ft):
        return (Fsus + Ff) / ms - GRAV, (Ft - Fsus - Ff) / mu - GRAV

    def f_hold(Fsus, Ft):
        """The friction force that keeps the relative acceleration zero (the suspension locked)."""
        return Ft * ms / (ms + mu) - Fsus

    def make_rhs(mode):
        # mode: +1 / −1 slipping with v of that sign (friction −mode·F_c); 0 stuck; None no stick-slip
        def rhs(t, x):
            Fsus, Ft, s, v = parts(t, x)
            if mode is None:
                Ff = -Fc * math.tanh(v / veps) if tanh_law else 0.0
            elif mode == 0:
                Ff = f_hold(Fsus, Ft)
            else:
                Ff = -mode * Fc
            a_s, a_u = accel(Fsus, Ff, Ft)
            if mode == 0:
                a_u = a_s  # exactly locked
            dFa = (u_cmd(t) - x[4]) / tau if tau > 0 else 0.0
            return [x[1], a_s, x[3], a_u, dFa, dz(x)]
        return rhs

    x0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    # start at the true static equilibrium (a heavier car has settled before the record starts)
    if ms != ms_nom:
        x0 = _static_equilibrium(lambda s: susp(s, 0.0, 0.0), ms, mu, kt, F_t0) + [0.0]
    opts = dict(method="DOP853", rtol=1e-9, atol=1e-12, max_step=2.0 / fs)
    sol = solve_ivp(make_rhs(None), (0, t_eval[-1]), x0, t_eval=t_eval, **opts)
    if sol.status != 0:
        raise RuntimeError(sol.message)
    X = sol.y
    modes = np.full(len(t_eval), np.nan)
    stick_slip = False
    # the outputs at the samples
    acc_s, acc_u, Ftot = np.empty(len(t_eval)), np.empty(len(t_eval)), np.empty(len(t_eval))
    for j, t in enumerate(t_eval):
        xj = X[:, j]
        Fsus, Ft, s, v = parts(t, xj)
        md = modes[j]
        if md != md:
            Ff = -Fc * math.tanh(v / veps) if tanh_law else 0.0
        elif md == 0:
            Ff = f_hold(Fsus, Ft)
        else:
            Ff = -md * Fc
        acc_s[j], acc_u[j] = accel(Fsus, Ff, Ft)
        if md == 0:
            acc_u[j] = acc_s[j]
        Ftot[j] = Ft
    s = X[0] - X[2]
    out = {"time": t_eval, "road": road_src.sample(t_eval), "force": force_src.sample(t_eval),
           "body_acc": acc_s, "wheel_acc": acc_u, "susp_travel": s, "tire_force_total": Ftot,
           "stick_share": float(np.mean(modes == 0)) if stick_slip else 0.0,
           # the travel at the car's own static equilibrium (a heavier car's sag below the nominal ride height,
           # negative; 0 for the nominal mass): a sensor zeroed where the car settled reads travel less this
           "travel_static": float(x0[0] - x0[2]),
           "lift_share": float(np.mean(Ftot <= 0.0)) if lift else 0.0}
    if stops:
        out["stop_share"] = float(np.mean(stop_engaged(s, stops)))
    return out


def stop_engaged(s, stops) -> np.ndarray:
    """The samples of travel ``s`` beyond the stops {gap_c, gap_e} (None: no stop on that side)."""
    eng = np.zeros(len(s), bool)
    if stops["gap_c"] is not None:
        eng |= s < -stops["gap_c"]
    if stops.get("gap_e") is not None:
        eng |= s > stops["gap_e"]
    return eng


def _static_equilibrium(fsusp, ms, mu, kt, F_t0):
    """(zs, 0, zu, 0, 0) where the suspension carries ms·g and the tyre (ms + mu)·g."""
    from scipy.optimize import brentq

    s = brentq(lambda s: fsusp(s) - ms * GRAV, -2.0, 2.0)
    zu = -((ms + mu) * GRAV - F_t0) / kt
    return [zu + s, 0.0, zu, 0.0, 0.0]


# ------------------------------------------------------------------------------------------------------
# sensors
# ------------------------------------------------------------------------------------------------------
def noise(rng, n: int, colour: str) -> np.ndarray:
    """Unit-std noise: white, pink (1/f power), brown (1/f² power above 0.2 Hz at 1 kHz) or band-limited (flat
    between 2 % and 8 % of the sample rate, 20–80 Hz at 1 kHz: a sensor's resonance or electrical pickup; nothing
    elsewhere), by FFT shaping."""
    w = rng.standard_normal(n)
    if colour == "white":
        return w
    f = np.fft.rfftfreq(n)
    f0 = 2e-4  # the lowest shaped frequency (0.2 Hz at 1 kHz)
    shape = {"pink": 1.0 / np.sqrt(np.maximum(f, f0)), "brown": 1.0 / np.maximum(f, f0),
             "band": ((f >= 0.02) & (f <= 0.08)).astype(float)}[colour]
    x = np.fft.irfft(np.fft.rfft(w) * shape, n)
    return x / np.std(x)
