"""Road and input library: shapes, random-road spectra, seeding, tracks, rear-wheel delay, measured profiles.

PSD tolerance (ISO 8608 and Hac roads).  A Welch estimate (Hann window, 50 % overlap, K segments) of a
Gaussian process at one frequency bin has a relative standard deviation ≈ √(1.056/K) (Welch 1967: the
factor 1 + 2ρ² with ρ = 0.167 for Hann at 50 % overlap).  Averaging the M bins of an octave band divides
the variance by M/1.94 (adjacent Hann bins are correlated: |ρ|² = 4/9 for neighbours, 1/36 for the next),
so the band mean has σ ≈ √(1.056·1.94/(K·M)).  We compare octave-band means with the target and allow
±20 %; each test first asserts that 20 % ≥ 4σ in every band of its estimate (a correct generator then
fails with probability < 10⁻⁴ per band), so the tolerance follows from the estimator's variance and the
record length, not from the result.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.signal import welch

import suspension_sim as ss
from suspension_sim.config import parse_scenario
from suspension_sim.errors import ScenarioError
from suspension_sim.registry import ROADS, VEHICLES
from suspension_sim.roads.base import RoadContext

TOL = 0.20


def make(name, params=None, ctx=None, seed=0):
    cls = ROADS.get(name)
    p = cls.Params.model_validate(params or {})
    ctx = ctx or RoadContext(duration=10.0, distance=200.0, wheelbase=0.0, mean_speed=20.0, dt=5e-4)
    return cls(p, np.random.default_rng(seed), ctx)


def octave_ratios(z, dx, target, n_lo, n_oct, nperseg):
    """Ratio of Welch octave-band means to the target's, and each band's σ (see module docstring)."""
    f, P = welch(z, fs=1.0 / dx, nperseg=nperseg)
    K = (len(z) - nperseg) // (nperseg // 2) + 1
    ratios, sig = [], []
    for k in range(n_oct):
        m = (f >= n_lo * 2 ** k) & (f < n_lo * 2 ** (k + 1))
        ratios.append(P[m].mean() / target(f[m]).mean())
        sig.append(np.sqrt(1.056 * 1.94 / (K * m.sum())))
    return np.array(ratios), np.array(sig)


def test_all_roads_registered():
    for name in ("flat", "sine", "bump", "half_sine", "round_step", "multi_sine", "chirp", "iso8608", "hac",
                 "profile"):
        assert name in ROADS
        assert ROADS.get(name).__doc__.strip()


# ---------------------------------------------------------------------------------------------------
# deterministic shapes

def test_bump_spatial_shape_peak_and_extent():
    r = make("bump", {"length": 4.0, "start": 10.0, "height": 0.06})
    x = np.linspace(0, 20, 20001)
    z = r.height(x / 20, x)
    assert z[x < 10].max() == 0 and z[x > 14].max() == 0
    assert z.max() == pytest.approx(0.06, rel=1e-9) and x[np.argmax(z)] == pytest.approx(12.0, abs=1e-3)
    assert np.trapezoid(z, x) == pytest.approx(0.06 * 4.0 / 2, rel=1e-6)  # mean of (1-cos)/2 is 1/2
    inside = (x >= 10) & (x <= 14)
    assert np.allclose(z[inside], 0.03 * (1 - np.cos(2 * np.pi * (x[inside] - 10) / 4)), atol=1e-15)


def test_bump_lin_kanellakopoulos_eq24():
    """Eq. (24): r = a(1 − cos 8πt) for 0.5 ≤ t ≤ 0.75 s, else 0, a = 0.04 m (8 cm high)."""
    r = make("bump", {"preset": "lin_kanellakopoulos"})
    t = np.linspace(0, 1.5, 15001)
    expected = np.where((t >= 0.5) & (t <= 0.75), 0.04 * (1 - np.cos(8 * np.pi * t)), 0.0)
    assert np.max(np.abs(r.height(t, 20 * t) - expected)) < 1e-12
    assert r.height(np.array([0.625]), np.array([0.0]))[0] == pytest.approx(0.08)
    # an explicit field overrides the preset, and the preset's time form can be swapped for a length
    assert make("bump", {"preset": "lin_kanellakopoulos", "height": 0.1}).p.height == 0.1
    p = make("bump", {"preset": "lin_kanellakopoulos", "length": 2.0}).p
    assert p.length == 2.0 and p.duration is None


def test_bump_fallah_preset_is_spatial_and_repeat_track_options():
    r = make("bump", {"preset": "fallah"})
    assert r.p.length == 5.0 and r.p.duration is None
    r2 = make("bump", {"length": 1.0, "start": 2.0, "repeat": 3, "period": 4.0, "track": "right"})
    x = np.linspace(0, 20, 4001)
    assert np.all(r2.height(x, x, track=0) == 0)
    z = r2.height(x, x, track=1)
    peaks = x[(z > 0.0499)]
    assert np.allclose(np.unique(np.round(peaks, 1)), [2.5, 6.5, 10.5])  # starts 2, 6, 10; peaks mid-length


def test_pulse_params_need_exactly_one_of_length_or_duration():
    with pytest.raises(ScenarioError, match="length"):
        parse_scenario({"road": {"type": "bump", "params": {"height": 0.1}}})
    with pytest.raises(ScenarioError, match="road.params"):
        parse_scenario({"road": {"type": "half_sine", "params": {"length": 1.0, "duration": 1.0}}})


def test_half_sine_shape_and_slope_jump():
    r = make("half_sine", {"duration": 0.2, "start": 1.0, "height": -0.03})
    t = np.linspace(0.9, 1.3, 40001)
    z = r.height(t, 20 * t)
    assert z.min() == pytest.approx(-0.03, rel=1e-8) and t[np.argmin(z)] == pytest.approx(1.1, abs=1e-5)
    assert np.all(z[(t < 1.0) | (t > 1.2)] == 0)
    slope = np.gradient(z, t)
    assert np.abs(slope[(t > 1.0) & (t < 1.0005)]).min() > 0.9 * np.pi * 0.03 / 0.2  # slope jumps at entry


def test_round_step_and_pulse():
    h, tau, t0 = 0.05, 0.04, 0.3
    step = make("round_step", {"height": h, "time_constant": tau, "start": t0})
    t = np.linspace(0, 2, 200001)
    z = step.height(t, t)
    assert np.all(z[t < t0] == 0) and z[-1] == pytest.approx(h, rel=1e-9)
    u50 = brentq(lambda u: 1 - (1 + u) * np.exp(-u) - 0.5, 0.1, 10)  # independent solve: ≈ 1.678
    assert t[np.argmin(np.abs(z - h / 2))] == pytest.approx(t0 + u50 * tau, abs=2e-5)
    assert np.all(np.diff(z) >= -1e-15)  # monotone rise
    pulse = make("round_step", {"shape": "pulse", "height": h, "length_constant": 0.5, "start": 2.0})
    x = np.linspace(0, 20, 200001)
    zp = pulse.height(x / 10, x)
    assert zp.max() == pytest.approx(h, rel=1e-8) and x[np.argmax(zp)] == pytest.approx(3.0, abs=1e-3)
    assert abs(zp[-1]) < 1e-6 * h


def test_multi_sine_matches_sum_and_starts_at_zero():
    A, f, ph = [0.01, 0.004, 0.002], [1.0, 3.5, 11.0], [0.0, 1.0, -2.0]
    r = make("multi_sine", {"amplitudes": A, "frequencies": f, "phases": ph, "start": 0.5})
    t = np.linspace(0, 3, 3001)
    ref = sum(a * (np.sin(2 * np.pi * fi * (t - 0.5) + p) - np.sin(p)) for a, fi, p in zip(A, f, ph))
    assert np.allclose(r.height(t, t), np.where(t >= 0.5, ref, 0.0), atol=1e-15)
    assert r.height(np.array([0.5]), np.array([0.0]))[0] == pytest.approx(0.0, abs=1e-15)
    rs = make("multi_sine", {"amplitudes": [0.01], "wavelengths": [4.0], "fade_in": 2.0})
    x = np.linspace(0, 40, 4001)
    assert np.allclose(rs.height(x, x)[x >= 2.0], 0.01 * np.sin(2 * np.pi * x[x >= 2.0] / 4.0))
    with pytest.raises(ScenarioError, match="same length"):
        parse_scenario({"road": {"type": "multi_sine", "params": {"amplitudes": [1, 2], "frequencies": [1]}}})


@pytest.mark.parametrize("method", ["linear", "logarithmic"])
def test_chirp_sweeps_the_band(method):
    f0, f1, T = 1.0, 16.0, 8.0
    r = make("chirp", {"amplitude": 0.01, "f0": f0, "f1": f1, "duration": T, "start": 1.0, "method": method})
    t = np.linspace(0, 10, 400001)
    z = r.height(t, t)
    assert np.all(z[(t < 1.0) | (t > 9.0)] == 0) and np.abs(z).max() <= 0.01 + 1e-15
    # cycles swept = ∫ f dt: linear (f0+f1)/2·T, logarithmic (f1 − f0)·T/ln(f1/f0)
    cycles = (f0 + f1) / 2 * T if method == "linear" else (f1 - f0) * T / np.log(f1 / f0)
    crossings = np.count_nonzero(np.diff(np.signbit(z[(t > 1.0) & (t < 9.0)])))
    assert crossings == pytest.approx(2 * cycles, abs=3)
    # instantaneous frequency near the middle of the sweep (zero-crossing spacing)
    tm = 5.0
    f_mid = f0 + (f1 - f0) * (tm - 1) / T if method == "linear" else f0 * (f1 / f0) ** ((tm - 1) / T)
    win = (t > tm - 0.25) & (t < tm + 0.25)
    n_cross = np.count_nonzero(np.diff(np.signbit(z[win])))
    assert n_cross / 2 / 0.5 == pytest.approx(f_mid, rel=0.1)


# ---------------------------------------------------------------------------------------------------
# ISO 8608

def test_iso8608_class_values():
    from suspension_sim.roads.iso8608 import CLASS_GD_N0, iso8608_psd

    assert CLASS_GD_N0["A"] == pytest.approx(16e-6) and CLASS_GD_N0["C"] == pytest.approx(256e-6)
    assert CLASS_GD_N0["H"] == pytest.approx(262144e-6)
    assert iso8608_psd(0.2, 256e-6) == pytest.approx(64e-6)  # (0.2/0.1)^-2 = 1/4
    assert make("iso8608", {"road_class": "E"}).p.gd == pytest.approx(4096e-6)
    assert make("iso8608", {"gd_n0": 1e-4, "road_class": "E"}).p.gd == 1e-4


@pytest.mark.parametrize("amplitudes", ["random", "deterministic"])
def test_iso8608_psd_matches_target(amplitudes):
    from suspension_sim.roads.iso8608 import iso8608_psd

    L, dx, nper = 40000.0, 0.05, 8192
    ctx = RoadContext(duration=L / 20, distance=L, wheelbase=0.0, mean_speed=20.0, dt=5e-4)
    # generated band wider than the checked ISO band (0.011–2.83), so window leakage at the generated band
    # edges does not bias the checked octaves
    r = make("iso8608", {"road_class": "D", "n_min": 0.005, "n_max": 5.0, "amplitudes": amplitudes}, ctx, seed=3)
    x = np.arange(10.0, L, dx)
    z = r.height(x / 20, x)
    ratios, sig = octave_ratios(z, dx, lambda n: iso8608_psd(n, 1024e-6), 0.011, 8, nper)
    assert np.all(4 * sig <= TOL), sig
    assert np.all(np.abs(ratios - 1) < TOL), ratios
    # variance: ∫ Gd dn over the generated band (w = 2): Gd(n0)·n0²·(1/n_min − 1/n_max)
    var = 1024e-6 * 0.01 * (1 / 0.005 - 1 / 5.0)
    assert np.var(r.profiles[0].z) == pytest.approx(var, rel=0.25 if amplitudes == "random" else 0.02)


def test_iso8608_seeded_tracks_and_fade_in():
    ctx = RoadContext(duration=10, distance=200, wheelbase=2.7, mean_speed=20, dt=5e-4, n_tracks=2)
    x = np.linspace(-2.7, 210, 5000)
    a, b, c = (make("iso8608", {}, ctx, seed=s).height(x, x) for s in (1, 1, 2))
    assert np.array_equal(a, b) and not np.allclose(a, c)
    # start at equilibrium: flat behind the start line (where the rear wheels stand), full road after fade_in
    assert np.all(a[x <= 0] == 0) and np.abs(a[x > 5]).max() > 0
    same = make("iso8608", {}, ctx, seed=1)
    assert np.array_equal(same.height(x, x, 0), same.height(x, x, 1))
    ctx_ind = RoadContext(duration=10, distance=200, wheelbase=2.7, mean_speed=20, dt=5e-4, n_tracks=2,
                          tracks="independent")
    ind = make("iso8608", {}, ctx_ind, seed=1)
    zl, zr = ind.height(x, x, 0), ind.height(x, x, 1)
    assert np.array_equal(zl, a)  # left track unchanged by the option
    assert abs(np.corrcoef(zl[x > 5], zr[x > 5])[0, 1]) < 0.9
    nofade = make("iso8608", {"fade_in": 0}, ctx, seed=1)
    assert nofade.height(np.array([-2.7]), np.array([-2.7]))[0] != 0  # generated from −wheelbase on


def test_scenario_tracks_reach_the_road():
    from suspension_sim.simulation import Simulation

    sc = parse_scenario({"road": {"type": "iso8608", "tracks": "independent"}, "sim": {"duration": 0.01}})
    assert Simulation([sc]).roads[0].ctx.tracks == "independent"


# ---------------------------------------------------------------------------------------------------
# Hac (thesis Ch. 2)

@pytest.mark.parametrize("road", ["asphalt", "dirt"])
def test_hac_filter_realises_eq_2_1(road):
    from suspension_sim.roads.hac import HAC_COEFFICIENTS, hac_psd, hac_shaping_filter
    from scipy.linalg import solve_continuous_lyapunov

    w = np.logspace(-3, 3, 200)
    for v in (5.0, 20.0):
        A, B, C = hac_shaping_filter(road, v)
        assert A.shape == (3, 3) and B.shape == (3, 1) and C.shape == (1, 3)
        assert np.all(np.linalg.eigvals(A).real < 0)
        H = np.array([(C @ np.linalg.solve(1j * wi * np.eye(3) - A, B))[0, 0] for wi in w])
        # unit-intensity white noise has two-sided PSD 1/(2π) per rad/s
        assert np.allclose(np.abs(H) ** 2 / (2 * np.pi), hac_psd(w, road, v), rtol=1e-9)
        P = solve_continuous_lyapunov(A, -B @ B.T)
        m = HAC_COEFFICIENTS[road]
        # stationary variance of w = μ4 + μ5 (Eq. 2.1 is the transform of μ4 e^(−μ1|ξ|) + μ5 e^(−μ2|ξ|) cos μ3ξ)
        assert P[0, 0] == pytest.approx(m[3] + m[4], rel=1e-9)
        # the printed (thesis) ε0 variant is within 3 % of Eq. 2.1
        At, Bt, Ct = hac_shaping_filter(road, v, thesis_eps0=True)
        Ht = np.array([(Ct @ np.linalg.solve(1j * wi * np.eye(3) - At, Bt))[0, 0] for wi in w])
        assert np.allclose(np.abs(Ht) ** 2 / (2 * np.pi), hac_psd(w, road, v), rtol=0.03)
    # the road is spatial: S_v(ω) = S_1(ω/v)/v
    assert np.allclose(hac_psd(w, road, 20.0), hac_psd(w / 20.0, road, 1.0) / 20.0)


@pytest.mark.parametrize("surface", ["asphalt", "dirt"])
def test_hac_generated_psd_matches_target(surface):
    from suspension_sim.roads.hac import hac_spatial_psd

    L, dx = 40000.0, 0.02
    ctx = RoadContext(duration=L / 20, distance=L, wheelbase=0.0, mean_speed=20.0, dt=5e-4)
    r = make("hac", {"surface": surface}, ctx, seed=5)
    x = np.arange(10.01, L, dx)  # between the generation grid's points: goes through the spline
    z = r.height(x / 20, x)
    ratios, sig = octave_ratios(z, dx, lambda n: hac_spatial_psd(n, surface), 0.01, 8, 2 ** 15)
    assert np.all(4 * sig <= TOL), sig
    assert np.all(np.abs(ratios - 1) < TOL), ratios


def test_hac_temporal_psd_at_vehicle_speed():
    """Sampled in time at 20 m/s (as the simulation does), the road has the thesis's S(ω; v) (one-sided per
    Hz: 4π·S(2πf)) — the spatial generation is the filter at the vehicle speed."""
    from suspension_sim.roads.hac import hac_psd

    v, T, dt = 20.0, 1000.0, 0.002
    ctx = RoadContext(duration=T, distance=v * T, wheelbase=0.0, mean_speed=v, dt=dt)
    r = make("hac", {"surface": "dirt"}, ctx, seed=11)
    t = np.arange(1.0, T, dt)
    z = r.height(t, v * t)
    ratios, sig = octave_ratios(z, dt, lambda f: 4 * np.pi * hac_psd(2 * np.pi * f, "dirt", v), 0.5, 6, 2 ** 14)
    assert np.all(4 * sig <= TOL), sig
    assert np.all(np.abs(ratios - 1) < TOL), ratios


def test_hac_seeded_and_faded():
    ctx = RoadContext(duration=10, distance=200, wheelbase=3.0, mean_speed=20, dt=5e-4)
    x = np.linspace(-3, 200, 3000)
    a, b, c = (make("hac", {"surface": "dirt"}, ctx, seed=s).height(x, x) for s in (4, 4, 5))
    assert np.array_equal(a, b) and not np.allclose(a, c)
    assert np.all(a[x <= 0] == 0) and np.std(a[x > 5]) > 0.005
    with pytest.raises(ScenarioError, match="mu"):
        parse_scenario({"road": {"type": "hac", "params": {"mu": [1, 2, 3]}}})


@pytest.mark.parametrize("surface", ["asphalt", "dirt"])
def test_a_long_run_drives_a_periodic_hac_road_of_bounded_size(surface):
    """Past 20 km the Hac road is one period (the filter's samples, the last 200 m blended into the first)
    repeated without a seam, so its memory does not grow with the duration (before: the whole distance, 153
    bytes of peak per 2 cm sample, ~1.5 GB at 1e4 s, ~15 GB at 1e5 s); the PSD is still Hac's, and a shorter
    road is the filter's output as before, sample for sample."""
    import time
    import tracemalloc

    from suspension_sim.roads._common import MAX_LENGTH, GriddedProfile, PeriodicProfile
    from suspension_sim.roads.hac import HAC_COEFFICIENTS, Hac, HacParams, generate_hac, hac_spatial_psd

    p = HacParams(surface=surface)
    ctx = dict(wheelbase=2.5, mean_speed=20.0, dt=5e-4)
    # a run shorter than the period: the filter's samples over [-wheelbase, distance + margin], unchanged
    short = Hac(p, np.random.default_rng(3), RoadContext(duration=500.0, distance=10_000.0, **ctx))
    n = int(np.ceil((10_000.0 + 50.0 + 2.5) / p.dx)) + 2
    assert type(short.profiles[0]) is GriddedProfile
    assert np.array_equal(short.profiles[0].z, generate_hac(p.road, np.random.default_rng(3), n, p.dx))
    sizes = []
    for dur in (1.25e3, 1e4, 1e5):
        tracemalloc.start()
        t0 = time.process_time()
        road = Hac(p, np.random.default_rng(3), RoadContext(duration=dur, distance=20.0 * dur, **ctx))
        cpu = time.process_time() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        prof = road.profiles[0]
        assert isinstance(prof, PeriodicProfile) and MAX_LENGTH <= prof.period < 1.01 * MAX_LENGTH
        assert peak < 400 * 2**20 and cpu < 20  # measured 183 MiB, 0.5 s at every duration
        sizes.append(prof.z.size)
    assert sizes[0] == sizes[1] == sizes[2]
    z, step = prof.z, np.diff(prof.z)
    assert abs(z[0] - z[-1]) < 5 * step.std()  # the seam is a step like any other (repeated raw: ~17x)
    assert np.std(z) == pytest.approx(np.sqrt(sum(HAC_COEFFICIENTS[surface][3:])), rel=0.1)  # μ4 + μ5
    x = np.arange(10.01, 2.5 * prof.period, p.dx)  # across two seams
    zz = road.height(x / 20, x)
    assert np.allclose(road.height(0.0, x[:1000] + prof.period), zz[:1000], rtol=0, atol=1e-9)  # x: 2e4 m
    ratios, sig = octave_ratios(zz[:int(prof.period / p.dx)], p.dx, lambda n: hac_spatial_psd(n, surface),
                                0.01, 8, 2 ** 15)
    assert np.all(np.abs(ratios - 1) < TOL), ratios


# ---------------------------------------------------------------------------------------------------
# delays, speed profiles

def _road_from_sim(road, model="quarter_car", speed=10.0, duration=3.0, vehicle_params=None):
    from suspension_sim.simulation import Simulation

    sc = parse_scenario({"vehicle": {"model": model, "params": vehicle_params or {}},
                         "road": {**road, "speed": speed}, "sim": {"duration": duration}})
    sim = Simulation([sc])
    z, zd = sim.road_chunk(0, sim.n_steps)[:2]
    return sim, np.arange(sim.n_steps) * sim.dt, z[0], zd[0]


@pytest.mark.skipif("half_car" not in VEHICLES, reason="half car model not available")
@pytest.mark.parametrize("road", [{"type": "bump", "params": {"length": 2.0, "start": 4.0, "height": 0.05}},
                                  {"type": "bump", "params": {"duration": 0.2, "start": 0.3, "height": 0.05}}])
def test_rear_wheel_meets_the_road_wheelbase_over_speed_later(road):
    v = 10.0
    sim, t, z, _ = _road_from_sim(road, "half_car", v, 1.5, {"a": 1.2, "b": 1.6})
    front, rear = sim.geom.corner_names.index("front"), sim.geom.corner_names.index("rear")
    delay = (1.2 + 1.6) / v
    assert np.allclose(z[:, rear], np.interp(t - delay, t, z[:, front], left=0.0), atol=1e-9)
    assert t[np.argmax(z[:, rear])] - t[np.argmax(z[:, front])] == pytest.approx(delay, abs=2 * sim.dt)


def test_spatial_bump_under_a_varying_speed():
    """Speed 0 → 10 m/s over 2 s: the front wheel reaches the bump at x = 5 m when ½·5·t² = 5 (t = √2);
    the road rate is dz/dx·v."""
    road = {"type": "bump", "params": {"length": 1.0, "start": 5.0, "height": 0.04}}
    sim, t, z, zd = _road_from_sim(road, speed=[[0.0, 0.0], [2.0, 10.0]], duration=3.0)
    first = t[np.argmax(z[:, 0] > 0)]
    assert first == pytest.approx(np.sqrt(2.0), abs=2 * sim.dt)
    x = 2.5 * t ** 2 * (t <= 2) + (10 + 10 * (t - 2)) * (t > 2)
    assert np.allclose(z[:, 0], np.where((x >= 5) & (x <= 6), 0.02 * (1 - np.cos(2 * np.pi * (x - 5))), 0),
                       atol=2e-4)
    v = np.minimum(5 * t, 10.0)
    dzdx = np.where((x >= 5) & (x <= 6), 0.02 * 2 * np.pi * np.sin(2 * np.pi * (x - 5)), 0)
    assert np.max(np.abs(zd[:, 0] - dzdx * v)) < 0.01 * np.max(np.abs(dzdx * v))


def test_a_long_run_with_a_speed_table_does_not_tabulate_every_step(monkeypatch):
    """A speed table was tabulated on the physics grid (24 bytes per step: 4.8 GB at 1e5 s); past
    MAX_GRID steps the same law runs in closed form, within a micrometre of the grid's (the grid interpolates
    the quadratic distance linearly between steps), and the rear wheels' time inverts it exactly."""
    import time
    import tracemalloc

    from suspension_sim.build import SpeedProfile

    table = [[0.0, 5.0], [3.0, 25.0], [10.0, 25.0], [12.5, 0.0], [14.0, 0.0], [16.0, 30.0]]
    for dur in (2.5e3, 1e5):  # 5e6 and 2e8 steps of 0.5 ms
        tracemalloc.start()
        t0 = time.process_time()
        sp = SpeedProfile(table, dur, 5e-4)
        cpu, peak = time.process_time() - t0, tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 2**20 and cpu < 1.0  # measured 4 KB, 1 ms
        assert sp.distance(dur) == pytest.approx(401.25 + 30 * (dur - 20))
        assert sp.max_distance == pytest.approx(sp.distance(dur + 5e-4)) and sp.mean(dur) > 29.0
    grid = SpeedProfile(table, 20.0, 5e-4)
    monkeypatch.setattr(SpeedProfile, "MAX_GRID", 100)
    closed = SpeedProfile(table, 20.0, 5e-4)
    assert grid.knots is None and closed.knots is not None
    t = np.linspace(-1.0, 25.0, 20001)
    assert np.abs(closed.distance(t) - grid.distance(t)).max() < 1e-6
    assert np.abs(closed.speed(t) - grid.speed(t)).max() < 1e-12
    moving = (t > 0) & ((t < 12.5) | (t > 14.0)) & (t < 20.0)  # standing still, the time is not unique
    assert np.allclose(closed.time_at(closed.distance(t[moving]), 0.0), t[moving], rtol=0, atol=1e-9)
    x = np.linspace(-5.0, grid.max_distance, 20001)
    assert np.abs(closed.time_at(x, 7.0) - grid.time_at(x, 7.0)).max() < 1e-5


def test_simulated_runs_with_each_road():
    for road in ({"type": "round_step", "params": {"time_constant": 0.05}},
                 {"type": "chirp", "params": {"duration": 0.5, "f0": 1, "f1": 5}},
                 {"type": "hac", "params": {"surface": "asphalt"}}):
        sc = parse_scenario({"road": {**road, "speed": 20}, "sim": {"duration": 0.5}})
        r = ss.simulate(sc)
        assert np.isfinite(r.ts["road"]).all()
        assert r.ts["road"].iloc[0] == 0.0


# ---------------------------------------------------------------------------------------------------
# measured profile

def test_ltu_profile_loads_detrends_and_resamples(real_data):
    f = real_data / "road_profile_ltu" / "ProfileData.csv"
    if not f.exists():
        pytest.skip("LTU profile not present")
    from suspension_sim.roads.profile import ProfileParams, load_profile

    p = ProfileParams(file=str(f), height_unit="mm", fade_in=0.0)
    d, h = load_profile(p)
    assert d[-1] == pytest.approx(19.999, abs=1e-6) and d.size == 20000
    assert abs(h.mean()) < 1e-9 and abs(np.polyfit(d, h, 1)[0]) < 1e-12  # linear trend removed
    assert 1e-3 < h.std() < 7e-3  # mm -> m (SOURCE.md: std 7.0 mm including offset and slope)
    ctx = RoadContext(duration=1.5, distance=15.0, wheelbase=0.0, mean_speed=10.0, dt=5e-4)
    r = make("profile", {"file": str(f), "height_unit": "mm", "fade_in": 0.0}, ctx)
    xs = d[100:15000:97]
    assert np.allclose(r.height(xs / 10, xs), h[100:15000:97], atol=1e-12)  # spline through the samples
    # run through the simulator at 10 m/s for 1.5 s (15 m of the 20 m profile)
    sc = parse_scenario({"road": {"type": "profile", "speed": 10.0,
                                  "params": {"file": str(f), "height_unit": "mm", "smoothing": 0.1}},
                         "sim": {"duration": 1.5}})
    res = ss.simulate(sc)
    assert np.isfinite(res.ts["road"]).all() and res.ts["road"].abs().max() > 1e-3
    with pytest.raises(ScenarioError, match="beyond_end"):
        ss.simulate(parse_scenario({"road": {"type": "profile", "speed": 20.0,
                                             "params": {"file": str(f), "height_unit": "mm"}},
                                    "sim": {"duration": 1.5}}))


def _csv(tmp_path, text, name="p.csv"):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


def test_profile_csv_errors_are_one_line_and_name_file_and_column(tmp_path):
    good = "dist,h\n0,1\n1,2\n2,1\n3,0\n4,1\n"
    ctx = RoadContext(duration=0.3, distance=3.0, wheelbase=0.0, mean_speed=10.0, dt=5e-4)
    r = make("profile", {"file": _csv(tmp_path, good), "distance_column": "dist", "height_column": "h",
                         "height_unit": "mm", "detrend": "none", "fade_in": 0}, ctx)
    assert r.height(np.array([0.0]), np.array([2.0]))[0] == pytest.approx(0.001)
    cases = [
        ("missing.csv", None, "h", "not found"),
        ("nocol.csv", "dist,height\n0,1\n1,2\n2,3\n3,4\n", "h", "missing column"),
        ("order.csv", "dist,h\n0,1\n1,2\n1,3\n3,4\n", "dist", "increase"),
        ("nan.csv", "dist,h\n0,1\n1,\n2,3\n3,4\n", "h", "missing or non-numeric"),
        ("text.csv", "dist,h\n0,1\n1,abc\n2,3\n3,4\n", "h", "non-numeric"),
    ]
    for name, text, col, msg in cases:
        path = _csv(tmp_path, text, name) if text is not None else str(tmp_path / name)
        with pytest.raises(ScenarioError) as err:
            make("profile", {"file": path, "distance_column": "dist", "height_column": "h"}, ctx)
        s = str(err.value)
        assert "\n" not in s and name in s and msg in s
        if msg != "not found":
            assert col in s
    # column numbers for a file without a header
    r = make("profile", {"file": _csv(tmp_path, "0;5\n1;6\n2;5\n3;4\n", "nohdr.csv"), "header": False,
                         "distance_column": 0, "height_column": 1, "delimiter": ";", "detrend": "mean",
                         "fade_in": 0}, ctx)
    assert r.height(np.array([0.0]), np.array([1.0]))[0] == pytest.approx(1.0)
