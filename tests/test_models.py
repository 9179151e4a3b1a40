"""Vehicle models against independent analytic models: frequency responses, static sag, natural frequencies,
SDOF free and force responses, the MJCF files on their own, the half car's pitch sign and rear road delay.

The analytic models below are written from the equations of motion (masses, springs, dampers, tires), not
from the MJCF or any ``suspension_sim`` code: ``M q'' + C q' + K q = Σ_i (K_i + s C_i) w_i`` with the road
inputs ``w_i``; transfer functions ``H(jω) = O (−ω² M + jω C + K)⁻¹ (K_i + jω C_i)``.

Frequency responses (``test_frequency_response_*``): one MuJoCo ensemble per model and band, one car per
frequency (13 frequencies, 0.1–30 Hz), each driven by a sine road ``A·sin(ωt)`` faded in with a half cosine;
the steady-state complex amplitude is a least-squares fit of ``c0 + p·cos ωt + q·sin ωt`` plus the decaying
free modes of the analytic model (so the window need not wait for the transient) over a whole number of
periods.  The error is the complex one, ``|H_sim/H − 1|`` (magnitude and phase together).

Integration error, measured: at the default step dt = 0.5 ms MuJoCo's default ``implicitfast`` integrator
gives complex errors up to 4.7 % at 30 Hz on the quarter car (a phase lag ≈ ω·dt/2; magnitude errors ≤ 0.7 %,
largest near wheel hop): the damper between body and wheel is a tendon spanning two kinematic trees, and the
implicit integrators treat its cross terms explicitly; the implicit diagonal term also acts as an added mass
c·dt (0.17 % of the sprung mass).  Both are O(dt) (``test_natural_frequencies`` checks that the eigenvalue
error halves with dt).  The scenario option ``sim.integrator: RK4`` (road plates kept kinematic within each
step) removes this: at the default dt = 0.5 ms the quarter-car errors are ≤ 0.15 % up to 30 Hz.  So these
tests run the linear plant with ``RK4`` at the default step, which is what the issue's 0.5 % asks of a
MuJoCo run; ``test_frequency_response_implicitfast_error`` records the default integrator's error.

The half car has two road inputs (front, rear delayed by wheelbase/speed).  Two cars per frequency, one with
no delay (very high speed) and one with a quarter-period delay, give both columns of the 2-input transfer
function; the error per output is ‖H_sim − H‖/‖H‖ over the two inputs (a single delayed input would make
relative errors meaningless where front and rear cancel).  Two parameter sets: the defaults (bounce and
pitch decoupled) and an asymmetric car (a ≠ b, front ≠ rear) that couples them.
"""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from suspension_sim.config import parse_scenario
from suspension_sim.registry import VEHICLES
from suspension_sim.simulation import Simulation
from suspension_sim.vehicles.base import equilibrium_preloads, models_dir

G = 9.81
TOL = 0.005  # the 0.5 %
FREQS = np.geomspace(0.1, 30.0, 13)
F_LOW, F_HIGH = FREQS[:7], FREQS[7:]  # 0.1 .. 1.73 Hz, 2.79 .. 30 Hz
BANDS = {  # dt, log_dt, fade-in, settling after the fade-in, fit window (s)
    "low": dict(freqs=F_LOW, dt=5e-4, log_dt=1e-3, fade=1.0, settle=0.5, window=10.0, integrator="RK4"),
    "high": dict(freqs=F_HIGH, dt=5e-4, log_dt=5e-4, fade=0.3, settle=0.2, window=0.5, integrator="RK4"),
}
AMP = 0.01  # m, road sine amplitude
ASYM_HALF = dict(a=1.2, b=1.7, sprung_mass=520.0, pitch_inertia=1000.0, unsprung_mass_front=40.0,
                 unsprung_mass_rear=50.0, spring_stiffness_rear=20000.0, damping_rear=1500.0,
                 tire_stiffness_rear=110000.0)


# ------------------------------------------------------------------------------------------------------
# independent analytic models
class Linear:
    """M q'' + C q' + K q = Σ_i (K_in[i] + s C_in[i]) w_i;  outputs y = O q + D w (position-like)."""

    def __init__(self, M, C, K, K_in, C_in, outputs):
        self.M, self.C, self.K = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (M, C, K))
        self.K_in = [np.asarray(k, dtype=float) for k in K_in]
        self.C_in = [np.asarray(c, dtype=float) for c in C_in]
        self.outputs = {k: (np.asarray(o, dtype=float), np.asarray(d, dtype=float)) for k, (o, d) in outputs.items()}

    def freq_response(self, f) -> dict[str, np.ndarray]:
        """Output -> complex array (n_f, n_inputs); ``<name>_acc`` = (jω)² × position output."""
        out = {k: np.zeros((len(f), len(self.K_in)), complex) for k in self.outputs}
        for n, fi in enumerate(f):
            s = 2j * np.pi * fi
            Z = self.M * s**2 + self.C * s + self.K
            for i, (k_in, c_in) in enumerate(zip(self.K_in, self.C_in)):
                q = np.linalg.solve(Z, k_in + s * c_in)
                for name, (o, d) in self.outputs.items():
                    out[name][n, i] = o @ q + d[i]
        for name in list(out):
            if name in ("body_z", "pitch"):
                out[ACC[name]] = out[name] * (2j * np.pi * np.asarray(f))[:, None] ** 2
        return out

    def eigenvalues(self) -> np.ndarray:
        """Oscillatory eigenvalues (upper half plane), by increasing |s|."""
        n = len(self.M)
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-np.linalg.solve(self.M, self.K), -np.linalg.solve(self.M, self.C)]])
        s = np.linalg.eigvals(A)
        s = s[s.imag > 1e-9]
        return s[np.argsort(np.abs(s))]


ACC = {"body_z": "body_acc", "pitch": "pitch_acc"}


def analytic(model: str, p) -> Linear:
    if model == "sdof":  # x: mass; base w
        m, k, c = p.sprung_mass, p.spring_stiffness, p.damping
        return Linear([[m]], [[c]], [[k]], [[k]], [[c]], {"body_z": ([1.0], [0.0]), "travel": ([1.0], [-1.0])})
    if model == "quarter_car":  # q = [body, wheel]; road w under the tire
        ms, mu, k, c, kt, ct = (p.sprung_mass, p.unsprung_mass, p.spring_stiffness, p.damping, p.tire_stiffness,
                                p.tire_damping)
        return Linear(np.diag([ms, mu]), [[c, -c], [-c, c + ct]], [[k, -k], [-k, k + kt]], [[0, kt]], [[0, ct]],
                      {"body_z": ([1, 0], [0]), "travel": ([1, -1], [0]), "wheel_z": ([0, 1], [0])})
    if model == "half_car":  # q = [heave z, pitch θ (nose down +), front wheel, rear wheel]; inputs front, rear
        a, b = p.a, p.b
        jf, jr = np.array([1, -a, -1, 0.0]), np.array([1, b, 0, -1.0])  # travel: body point above axle − wheel
        ef, er = np.array([0, 0, 1, 0.0]), np.array([0, 0, 0, 1.0])
        K = (p.spring_stiffness_front * np.outer(jf, jf) + p.spring_stiffness_rear * np.outer(jr, jr)
             + p.tire_stiffness_front * np.outer(ef, ef) + p.tire_stiffness_rear * np.outer(er, er))
        C = (p.damping_front * np.outer(jf, jf) + p.damping_rear * np.outer(jr, jr)
             + p.tire_damping_front * np.outer(ef, ef) + p.tire_damping_rear * np.outer(er, er))
        M = np.diag([p.sprung_mass, p.pitch_inertia, p.unsprung_mass_front, p.unsprung_mass_rear])
        z2 = [0.0, 0.0]
        return Linear(M, C, K, [p.tire_stiffness_front * ef, p.tire_stiffness_rear * er],
                      [p.tire_damping_front * ef, p.tire_damping_rear * er],
                      {"body_z": ([1, 0, 0, 0], z2), "pitch": ([0, 1, 0, 0], z2), "travel_front": (jf, z2),
                       "travel_rear": (jr, z2)})
    raise KeyError(model)


def params(model, **kw):
    return VEHICLES.get(model).Params(**kw)


# ------------------------------------------------------------------------------------------------------
# helpers
def scenario(model, vparams=None, road=None, speed=20.0, duration=1.0, dt=5e-4, log_dt=None, variations=(),
             controller=None, integrator="implicitfast"):
    log_dt = log_dt or dt
    raw = dict(vehicle=dict(model=model, params=vparams or {}, variations=list(variations)),
               road=dict(type="flat") if road is None else dict(road, speed=speed),
               sim=dict(duration=duration, dt=dt, control_dt=log_dt, log_dt=log_dt, integrator=integrator))
    if controller:
        raw["controller"] = controller
    return parse_scenario(raw)


def sine_amplitude(t, y, f, window, modes=()):
    """Complex amplitude Y of the steady sine in y (y ≈ Re(Y e^{jωt}) + c0 + free modes) over the last
    whole periods within ``window`` seconds."""
    w = 2 * np.pi * f
    n_per = max(1, int(np.floor(window * f + 1e-9)))
    t_end = t[-1] + (t[1] - t[0])
    sel = t >= t_end - n_per / f - 1e-9
    ts, ys = t[sel], y[sel]
    tt = ts - ts[0]
    cols = [np.ones_like(ts), np.cos(w * ts), np.sin(w * ts)]
    for lam in modes:
        env = np.exp(lam.real * tt)
        cols += [env * np.cos(lam.imag * tt), env * np.sin(lam.imag * tt)]
    c = np.linalg.lstsq(np.column_stack(cols), ys, rcond=None)[0]
    return c[1] - 1j * c[2]


def unique_modes(lin: Linear, rtol=1e-6):
    out = []
    for s in lin.eigenvalues():
        if all(abs(s - u) > rtol * abs(s) for u in out):
            out.append(s)
    return out


def band_runs(model, cars, band, integrator=None):
    """cars: list of (vehicle params dict, frequency, speed). One ensemble; returns the Results."""
    b = BANDS[band]
    max_tau = 0.0
    for vp, f, speed in cars:
        max_tau = max(max_tau, VEHICLES.get(model).wheelbase(params(model, **vp)) / speed)
    duration = round(b["fade"] + max_tau + b["settle"] + b["window"], 3)
    scs = [scenario(model, vp, dict(type="sine", params=dict(frequency=float(f), amplitude=AMP, fade_in=b["fade"])),
                    speed=speed, duration=duration, dt=b["dt"], log_dt=b["log_dt"],
                    integrator=integrator or b["integrator"]) for vp, f, speed in cars]
    return Simulation(scs).run()


# ------------------------------------------------------------------------------------------------------
# frequency responses
@pytest.mark.parametrize("model", ["quarter_car", "sdof"])
def test_frequency_response_one_input(model):
    p = params(model)
    lin = analytic(model, p)
    modes = unique_modes(lin)
    bands = ["low", "high"]
    errors = {}
    for band in bands:
        fb = BANDS[band]["freqs"]
        results = band_runs(model, [({}, f, 20.0) for f in fb], band)
        H = lin.freq_response(fb)
        for f, r, i in zip(fb, results, range(len(fb))):
            t = r.ts["t"].to_numpy()
            W = sine_amplitude(t, r.ts["road"].to_numpy(), f, BANDS[band]["window"])
            assert abs(W / (-1j * AMP) - 1) < 1e-9  # the road is A·sin(ω t) at the logged instants
            for ch in ("body_acc", "travel", "body_z"):
                Y = sine_amplitude(t, r.ts[ch].to_numpy(), f, BANDS[band]["window"], modes)
                errors[(ch, round(f, 3))] = abs(Y / (-1j * AMP) / H[ch][i, 0] - 1)
    worst = max(errors, key=errors.get)
    print(f"{model}: worst complex error {errors[worst]:.2e} at {worst}")
    bad = {k: f"{v:.2e}" for k, v in errors.items() if v > TOL}
    assert not bad, f"{model}: frequency response off by more than {TOL:.1%}: {bad}"


def test_trapezoidal_is_second_order_and_far_more_accurate():
    """The trapezoidal scheme (implicitfast with the dampers split and the body-wheel coupling supplied):
    road-to-body response of the quarter car at 9.4 and 30 Hz, at 0.5 and 0.25 ms."""
    lin = analytic("quarter_car", params("quarter_car"))
    modes = unique_modes(lin)
    fb = np.array([9.4, 30.0])
    H = lin.freq_response(fb)
    err = {}
    for integ, dt in (("implicitfast", 5e-4), ("trapezoidal", 5e-4), ("trapezoidal", 2.5e-4)):
        BANDS["tmp"] = dict(BANDS["high"], dt=dt, log_dt=dt)
        try:
            results = band_runs("quarter_car", [({}, f, 20.0) for f in fb], "tmp", integrator=integ)
        finally:
            del BANDS["tmp"]
        err[(integ, dt)] = max(abs(sine_amplitude(r.ts["t"].to_numpy(), r.ts["body_z"].to_numpy(), f, 0.5, modes)
                                   / (-1j * AMP) / H["body_z"][i, 0] - 1) for i, (f, r) in enumerate(zip(fb, results)))
    print(f"body_z complex error at 9.4/30 Hz: {err}")
    assert err[("trapezoidal", 5e-4)] < 0.1 * err[("implicitfast", 5e-4)]
    assert err[("trapezoidal", 2.5e-4)] < 0.35 * err[("trapezoidal", 5e-4)]  # second order: /4 (first: /2)
    assert err[("trapezoidal", 5e-4)] < TOL


def test_trapezoidal_refuses_what_it_cannot_do():
    from suspension_sim.errors import ScenarioError

    with pytest.raises(ScenarioError, match="damping\\*dt/mass"):
        Simulation([scenario("quarter_car", {"damping": 1e6}, integrator="trapezoidal")])
    with pytest.raises(ScenarioError, match="tires"):
        Simulation([scenario("sdof", integrator="trapezoidal")])


def test_frequency_response_implicitfast_error():
    """The default integrator's first-order error at the default step, measured (what the module docstring
    states): larger than RK4's by an order of magnitude near and above wheel hop, still below 5 %."""
    lin = analytic("quarter_car", params("quarter_car"))
    modes = unique_modes(lin)
    fb = np.array([9.4, 30.0])
    err = {}
    for integ in ("implicitfast", "RK4"):
        results = band_runs("quarter_car", [({}, f, 20.0) for f in fb], "high", integrator=integ)
        H = lin.freq_response(fb)
        err[integ] = max(abs(sine_amplitude(r.ts["t"].to_numpy(), r.ts["body_z"].to_numpy(), f, 0.5, modes)
                             / (-1j * AMP) / H["body_z"][i, 0] - 1) for i, (f, r) in enumerate(zip(fb, results)))
    print(f"body_z complex error at 9.4/30 Hz, dt = 0.5 ms: {err}")
    assert err["RK4"] < 0.2 * err["implicitfast"]
    assert 0.005 < err["implicitfast"] < 0.05


@pytest.mark.parametrize("integrator", ["RK4", "trapezoidal"])
def test_frequency_response_half_car(integrator):
    """Both inputs, both parameter sets, 0.1-30 Hz, within 0.5 % with RK4 and with the trapezoidal scheme
    (whose body-wheel damper coupling comes from the last step: this checks it for pitch too)."""
    model = "half_car"
    sets = {"default": {}, "asymmetric": ASYM_HALF}
    outputs = ("body_acc", "pitch", "pitch_acc", "travel_front", "travel_rear")
    errors = {}
    for band in ("low", "high"):
        fb = BANDS[band]["freqs"]
        cars, keys = [], []
        for name, vp in sets.items():
            L = VEHICLES.get(model).wheelbase(params(model, **vp))
            for f in fb:
                cars.append((vp, f, 1e7))  # no delay (τ = L/1e7 s, kept in the analytic model)
                cars.append((vp, f, 4 * f * L))  # quarter-period delay of the rear input
                keys.append((name, f))
        results = band_runs(model, cars, band, integrator=integrator)
        for k, (name, f) in enumerate(keys):
            p = params(model, **sets[name])
            lin = analytic(model, p)
            modes = unique_modes(lin)
            H = lin.freq_response([f])
            Ys, Es = [], []
            for r in results[2 * k: 2 * k + 2]:
                ts = r.ts
                t = ts["t"].to_numpy()
                speed = r.scenario.road.speed
                tau = (p.a + p.b) / speed
                win = BANDS[band]["window"]
                Wf = sine_amplitude(t, ts["road_front"].to_numpy(), f, win)
                Wr = sine_amplitude(t, ts["road_rear"].to_numpy(), f, win)
                assert abs(Wf / (-1j * AMP) - 1) < 1e-9
                # the loop delays the rear road by wheelbase/speed
                assert abs(Wr / Wf - np.exp(-2j * np.pi * f * tau)) < 1e-9
                Ys.append({ch: sine_amplitude(t, ts[ch].to_numpy(), f, win, modes) / Wf for ch in outputs})
                Es.append(np.exp(-2j * np.pi * f * tau))
            # Y_n = H_front + H_rear·e_n  (n = 1, 2)  ->  both columns of the 2-input transfer function
            E = np.array([[1, Es[0]], [1, Es[1]]])
            for ch in outputs:
                Hsim = np.linalg.solve(E, np.array([Ys[0][ch], Ys[1][ch]]))
                Han = H[ch][0]
                errors[(name, ch, round(f, 3))] = np.linalg.norm(Hsim - Han) / np.linalg.norm(Han)
    worst = max(errors, key=errors.get)
    print(f"half_car ({integrator}): worst error {errors[worst]:.2e} at {worst}")
    bad = {k: f"{v:.2e}" for k, v in errors.items() if v > TOL}
    assert not bad, f"half car frequency response off by more than {TOL:.1%}: {bad}"


# ------------------------------------------------------------------------------------------------------
# natural frequencies: linearise the MuJoCo plant (the loop's step map, road held) and compare eigenvalues
def mujoco_eigenvalues(model, vp, dt):
    sim = Simulation([scenario(model, vp, duration=dt, dt=dt)])
    P = sim.plant
    m = P.model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    nv = m.nv
    A = np.zeros((2 * nv, 2 * nv))
    mujoco.mjd_transitionFD(m, d, 1e-6, True, A, None, None, None)
    idx = np.concatenate([P.free_v, nv + P.free_v])  # road plates are set by the loop every step
    mu = np.linalg.eigvals(A[np.ix_(idx, idx)]).astype(complex)
    s = np.log(mu) / dt
    s = s[s.imag > 1e-9]
    return s[np.argsort(np.abs(s))]


@pytest.mark.parametrize("model,vp", [("quarter_car", {}), ("half_car", {}), ("half_car", ASYM_HALF), ("sdof", {})],
                         ids=["quarter_car", "half_car", "half_car_asymmetric", "sdof"])
def test_natural_frequencies(model, vp):
    """Natural frequencies and damping ratios of the MuJoCo model (discrete eigenvalues s = ln(μ)/dt) match
    the analytic model's within 0.5 % at the default dt, and the remaining difference is the integrator's
    first-order error: it halves when dt halves."""
    sa = analytic(model, params(model, **vp)).eigenvalues()
    errs = {}
    for dt in (5e-4, 2.5e-4):
        sm = mujoco_eigenvalues(model, vp, dt)
        assert len(sm) == len(sa)
        fn_err = np.abs(sm) / np.abs(sa) - 1
        zeta_err = (-sm.real / np.abs(sm)) / (-sa.real / np.abs(sa)) - 1
        errs[dt] = np.concatenate([fn_err, zeta_err])
        assert np.all(np.abs(fn_err) < TOL), (dt, np.abs(sa) / 2 / np.pi, fn_err)
        assert np.all(np.abs(zeta_err) < TOL), (dt, -sa.real / np.abs(sa), zeta_err)
    big = np.abs(errs[5e-4]) > 1e-4  # the ratio is meaningful where the error is well above FD noise
    ratio = np.abs(errs[5e-4][big] / errs[2.5e-4][big])
    assert np.all((ratio > 1.7) & (ratio < 2.3)), ratio


# ------------------------------------------------------------------------------------------------------
# static sag: add Δm to the sprung mass (vehicle.variations step at t = 0) and let it settle
def _settle(model, vp, dm, duration=8.0):
    sc = scenario(model, vp, duration=duration, dt=5e-4, log_dt=0.01,
                  variations=[dict(param="sprung_mass", kind="step", mode="add", times=[0.0], values=[dm])])
    ts = Simulation([sc]).run()[0].ts
    return ts[ts["t"] >= duration - 1.0].mean()


def test_static_sag_quarter_car():
    p, dm = params("quarter_car"), 60.0
    s = _settle("quarter_car", {}, dm)
    F = dm * G
    assert s["travel"] == pytest.approx(-F / p.spring_stiffness, rel=1e-3)  # m·g/k
    assert s["wheel_z"] == pytest.approx(-F / p.tire_stiffness, rel=1e-3)
    assert s["body_z"] == pytest.approx(-F / p.spring_stiffness - F / p.tire_stiffness, rel=1e-3)
    assert s["tire_force"] == pytest.approx(F, rel=1e-3)  # dynamic tire load, + = more compression


@pytest.mark.parametrize("vp", [{}, ASYM_HALF], ids=["default", "asymmetric"])
def test_static_sag_half_car(vp):
    p, dm = params("half_car", **vp), 100.0
    s = _settle("half_car", vp, dm)
    L = p.a + p.b
    Ff, Fr = dm * G * p.b / L, dm * G * p.a / L  # the added weight at the c.g., shared by the axles
    assert s["travel_front"] == pytest.approx(-Ff / p.spring_stiffness_front, rel=1e-3)
    assert s["travel_rear"] == pytest.approx(-Fr / p.spring_stiffness_rear, rel=1e-3)
    assert s["wheel_z_front"] == pytest.approx(-Ff / p.tire_stiffness_front, rel=1e-3)
    assert s["tire_force_rear"] == pytest.approx(Fr, rel=1e-3)
    zf = -Ff / p.spring_stiffness_front - Ff / p.tire_stiffness_front  # body point above the front axle
    zr = -Fr / p.spring_stiffness_rear - Fr / p.tire_stiffness_rear
    assert s["body_z"] == pytest.approx((p.b * zf + p.a * zr) / L, rel=1e-3)
    assert s["pitch"] == pytest.approx((zr - zf) / L, abs=1e-3 * abs(zf) / L + 1e-9)  # nose down when zf < zr


def test_a_car_heavier_than_it_was_levelled_with_starts_at_rest_at_its_sag():
    """``vehicle.levelled_with``: the half car carries 100 kg more than the sprung mass it was levelled with.  It
    starts at rest at the settled sag of the load-step test above (no drop, no ringing) and stays there; the same
    scenario without ``levelled_with`` is re-levelled (starts and stays at zero)."""
    p, dm = params("half_car"), 100.0
    L = p.a + p.b
    Ff, Fr = dm * G * p.b / L, dm * G * p.a / L
    sag = {"travel_front": -Ff / p.spring_stiffness_front, "travel_rear": -Fr / p.spring_stiffness_rear,
           "wheel_z_front": -Ff / p.tire_stiffness_front, "tire_force_rear": Fr}
    for levelled in (True, False):
        sc = scenario("half_car", {"sprung_mass": p.sprung_mass + dm}, duration=0.5, log_dt=0.01)
        if levelled:
            sc.vehicle.levelled_with = {"sprung_mass": p.sprung_mass}
        ts = Simulation([sc]).run()[0].ts
        for k, v in sag.items():
            at_sag = np.allclose(ts[k].to_numpy(), v, rtol=1e-6, atol=0)
            assert at_sag == levelled, (levelled, k, v, ts[k].to_numpy()[[0, -1]])
        assert np.max(np.abs(ts["body_acc"])) < 1e-6


# ------------------------------------------------------------------------------------------------------
# SDOF rig (no tire): free response after a mass step and force-input step response
def _sdof_step_response(t, x0, m, k, c):
    """Deviation from the final equilibrium of m x'' + c x' + k x = 0 with x(0) = x0, x'(0) = 0, and its
    acceleration."""
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    e = np.exp(-z * wn * t)
    x = x0 * e * (np.cos(wd * t) + z * wn / wd * np.sin(wd * t))
    v = -x0 * wn**2 / wd * e * np.sin(wd * t)
    return x, -(k * x + c * v) / m


def _nrmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def test_sdof_free_response():
    """+50 kg at t = 0: the mass falls from the old equilibrium to the new one, sag Δm·g/K, as the analytic
    damped oscillation (M = 300 kg, K = 5000 N/m, C = 250 N·s/m, ζ ≈ 0.10)."""
    p, dm = params("sdof"), 50.0
    sc = scenario("sdof", {}, duration=10.0, dt=5e-4, log_dt=1e-3,
                  variations=[dict(param="sprung_mass", kind="step", mode="add", times=[0.0], values=[dm])])
    ts = Simulation([sc]).run()[0].ts
    assert not any(c.startswith(("wheel", "tire")) for c in ts.columns)  # no tire, no wheel
    t = ts["t"].to_numpy()
    sag = dm * G / p.spring_stiffness
    x, a = _sdof_step_response(t, sag, p.sprung_mass + dm, p.spring_stiffness, p.damping)
    assert _nrmse(ts["body_z"].to_numpy() + sag, x) < TOL
    assert _nrmse(ts["body_acc"].to_numpy(), a) < TOL
    np.testing.assert_allclose(ts["travel"], ts["body_z"], atol=1e-12)  # flat base: travel = body position


def test_sdof_force_input():
    """Flat road (base at rest): the rig driven by the actuator alone, a 500 N step from t = 0 (open-loop
    command, ideal actuator): x = F/K·(1 − free response)."""
    p, F = params("sdof"), 500.0
    sc = scenario("sdof", {}, duration=10.0, dt=5e-4, log_dt=1e-3,
                  controller=dict(type="open_loop", params=dict(signal="constant", amplitude=F)))
    ts = Simulation([sc]).run()[0].ts
    t = ts["t"].to_numpy()
    x, a = _sdof_step_response(t, -F / p.spring_stiffness, p.sprung_mass, p.spring_stiffness, p.damping)
    assert np.allclose(ts["actuator_force"], F)
    assert _nrmse(ts["body_z"].to_numpy() - F / p.spring_stiffness, x) < TOL
    assert _nrmse(ts["body_acc"].to_numpy(), a) < TOL


# ------------------------------------------------------------------------------------------------------
# the MJCF files and the half car's geometry
@pytest.mark.parametrize("name", ["quarter_car", "half_car", "sdof"])
def test_mjcf_alone_at_equilibrium(name):
    """Each file loads in MuJoCo by itself, its spring lengths are the static preloads, and it stays at
    qpos = 0 under gravity (up to the road servos' compliance, load/kp ≈ 3e-6 m)."""
    path = models_dir() / f"{name}.xml"
    m = mujoco.MjModel.from_xml_path(str(path))
    stored = m.tendon_lengthspring[:, 0].copy()
    # rtol 1e-4: quarter_car.xml stores the tire preload as 0.01801872 m, m·g/k = 0.01801942 m (0.13 N off)
    np.testing.assert_allclose(stored, equilibrium_preloads(mujoco.MjModel.from_xml_path(str(path)))[0],
                               rtol=1e-4)
    d = mujoco.MjData(m)
    for _ in range(int(2.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    assert np.abs(d.qpos).max() < 1e-5 and np.abs(d.qvel).max() < 1e-5
    assert m.ngeom > 0 and not (m.geom_contype | m.geom_conaffinity).any()  # visible, no contacts


def test_half_car_geometry_and_pitch_sign():
    """a, b move the wheels and road plates and set the tendons' pitch coefficients; a positive pitch (MuJoCo
    hinge about +y) moves the front down: nose down, front travel −a·θ, rear travel +b·θ."""
    vp = dict(a=1.1, b=1.9)
    root = VEHICLES.get("half_car").build(params("half_car", **vp))
    m = mujoco.MjModel.from_xml_string(root.to_xml_string())
    d = mujoco.MjData(m)
    assert m.body("wheel_front").pos[0] == pytest.approx(1.1) and m.body("road_rear").pos[0] == pytest.approx(-1.9)
    theta = 0.01
    d.qpos[m.joint("pitch").qposadr[0]] = theta
    mujoco.mj_forward(m, d)
    nose0 = m.body("body").pos[2] + m.geom("body_nose").pos[2]
    assert d.geom("body_nose").xpos[2] < nose0 - 0.9 * 1.1 * theta
    assert d.ten_length[m.tendon("suspension_front").id] == pytest.approx(-1.1 * theta)
    assert d.ten_length[m.tendon("suspension_rear").id] == pytest.approx(1.9 * theta)
    cg = [c.x for c in VEHICLES.get("half_car").corners(params("half_car", **vp))]
    assert cg == [1.1, -1.9]


def test_half_car_rear_road_delay_varying_speed():
    """With a speed ramp the rear wheel sees the road where the front axle was: spatial sine at the front
    axle's distance x(t) − L, temporal sine at the time the front axle was there.  One ensemble of two cars
    with different wheelbases (3.0 and 2.9 m): each car's own wheelbase sets its delay."""
    A, lam, f = 0.01, 2.0, 1.5
    speed = [[0.0, 5.0], [2.0, 25.0]]  # v = 5 + 10 t, x = 5t + 5t²
    t_of_x = lambda x: (-5 + np.sqrt(25 + 20 * x)) / 10  # noqa: E731
    cars = [({}, 3.0), (ASYM_HALF, 2.9)]
    for road in (dict(type="sine", params=dict(wavelength=lam, amplitude=A)),
                 dict(type="sine", params=dict(frequency=f, amplitude=A))):
        scs = [scenario("half_car", vp, road, speed=speed, duration=2.0, dt=5e-4, log_dt=1e-3) for vp, _ in cars]
        for r, (_, L) in zip(Simulation(scs).run(), cars):
            ts = r.ts
            t = ts["t"].to_numpy()
            xr = 5 * t + 5 * t**2 - L
            if "wavelength" in road["params"]:
                front, rear = A * np.sin(2 * np.pi * (xr + L) / lam), A * np.sin(2 * np.pi * xr / lam)
            else:
                front, rear = A * np.sin(2 * np.pi * f * t), A * np.sin(2 * np.pi * f * t_of_x(np.maximum(xr, 0)))
            rear = np.where(xr >= 0, rear, 0.0)
            np.testing.assert_allclose(ts["road_front"], front, atol=1e-9)
            np.testing.assert_allclose(ts["road_rear"], rear, atol=1e-6)


def test_default_integrator_is_trapezoidal_where_stable_else_implicitfast(tmp_path):
    """``sim.integrator: auto`` (the default) is the trapezoidal scheme, bit for bit, where it applies and is
    stable, and implicitfast, bit for bit, where it is not (no tires; damping*dt/mass > 1); the choice and
    its reason reach the run's info and ``scenario.resolved.yaml``, which reruns with the same scheme."""
    from suspension_sim.config import SimCfg
    from suspension_sim.outputs import write_result

    assert SimCfg().integrator == "auto"
    road = dict(type="sine", params=dict(amplitude=0.01, frequency=9.4))
    cases = [("quarter_car", {}, "trapezoidal", "stable here"),
             ("quarter_car", {"damping": 1e6}, "implicitfast", "damping*dt/mass"),
             ("sdof", {}, "implicitfast", "without tires")]
    for model, vp, expect, why in cases:
        auto = Simulation([scenario(model, vp, road=road, duration=0.3, integrator="auto")])
        assert auto.integrator == expect and why in auto.integrator_reason, (model, vp, auto.integrator_reason)
        ra = auto.run()[0]
        rx = Simulation([scenario(model, vp, road=road, duration=0.3, integrator=expect)]).run()[0]
        assert ra.ts.equals(rx.ts), (model, vp)
        assert ra.info["integrator"] == expect and rx.info["integrator_reason"] == ""
    out = write_result(ra, tmp_path / "run", plots=False, timeseries=False)
    text = (out / "scenario.resolved.yaml").read_text()
    assert "  integrator: implicitfast  # auto: trapezoidal not usable (model without tires)" in text, text
    from suspension_sim.config import load_scenario
    assert load_scenario(out / "scenario.resolved.yaml").sim.integrator == "implicitfast"


def test_auto_reason_names_effects_that_hold_their_step_start_force():
    """``auto``'s "second order" is the linear suspension's: an effect that holds its step-start force over each
    step (``step_force: start``, the default) is first order in that force (tests/test_effects.py measures it),
    and the reason says so by name; with ``step_force: mean`` (second order) or without such an effect it does
    not."""
    road = dict(type="sine", params=dict(amplitude=0.01, frequency=2.0))
    reasons = {}
    for sf in ("start", "mean"):
        sc = scenario("quarter_car", road=road, duration=0.1, integrator="auto").model_dump()
        sc["vehicle"]["effects"] = [dict(type="bump_stop", params=dict(step_force=sf)),
                                    dict(type="quadratic_damping", params=dict(c_v=500.0))]
        sim = Simulation([parse_scenario(sc)])
        assert sim.integrator == "trapezoidal", sim.integrator_reason
        reasons[sf] = sim.integrator_reason
    assert "bump_stop, quadratic_damping hold the step-start force" in reasons["start"], reasons
    assert "quadratic_damping holds the step-start force" in reasons["mean"], reasons
    assert "bump_stop" not in reasons["mean"], reasons
    plain = Simulation([scenario("quarter_car", road=road, duration=0.1, integrator="auto")]).integrator_reason
    assert plain.startswith("auto: second order") and "hold" not in plain, plain
