"""The road rate ż_road is the exact time derivative of the height the wheel sees, for every registered road.

Both loops take the road rate from :meth:`System.road_chunk`, which asks each road for its own derivative law
(:meth:`Road.slopes`: the spline's analytic derivative for gridded roads, the closed-form derivative for the
analytic shapes).  It used to be a central difference over ±dt, whose O(dt²) error on a spline road (Ch. 5's
dirt road, 0.1 m grid, 20 m/s: the spline carries content up to ~50 Hz, (ω·dt)²/6 ≈ 1.6 % at 1 ms) made
results move with the step.

Tolerance: the delivered rate must match a fine central difference of the height (h = 1 µs: its own error is
below 1e-7 of the rate on these roads: z'''·v³·h²/6, and rounding ~1e-12 m/s) to ``TOL`` = 1e-4 of the largest
rate.  The old difference at dt = 1 ms fails this on every road but the flat one (by 4-1300x; on the spline
roads by 100-1300x: hac dirt 3.0e-2, ISO 8608 C 9.7e-3, the profile 0.12), so the test can fail.
"""
from __future__ import annotations

import numpy as np
import pytest

from suspension_sim.registry import ROADS, VEHICLES
from suspension_sim.roads.base import RoadContext

TOL = 1e-4
V = 20.0  # m/s
H = 1e-6  # s, the test's own difference step


def _profile_csv(tmp_path):
    rng = np.random.default_rng(3)
    d = np.arange(0.0, 150.0, 0.05)
    h = np.convolve(rng.standard_normal(d.size), np.ones(8) / 8, mode="same") * 5.0  # mm
    f = tmp_path / "profile.csv"
    f.write_text("Distance_m,Profile_mm\n" + "\n".join(f"{a:.3f},{b:.6f}" for a, b in zip(d, h)))
    return str(f)


# (road type, params, context distance): each registered road at least once, spatial and temporal forms
CASES = [
    ("flat", {}, 200.0),
    ("sine", {"frequency": 3.3, "start": 0.1, "fade_in": 0.2, "phase": 0.4}, 200.0),
    ("sine", {"wavelength": 2.7, "start": 1.0, "fade_in": 1.5, "amplitude": 0.02}, 200.0),
    ("bump", {"length": 2.0, "start": 1.0, "repeat": 3}, 200.0),
    ("bump", {"preset": "lin_kanellakopoulos"}, 200.0),
    ("half_sine", {"length": 1.5, "start": 2.0}, 200.0),
    ("half_sine", {"duration": 0.3, "start": 0.2}, 200.0),
    ("round_step", {"time_constant": 0.05, "start": 0.2}, 200.0),
    ("round_step", {"shape": "pulse", "length_constant": 0.5, "start": 3.0}, 200.0),
    ("multi_sine", {"amplitudes": [0.01, 0.005], "frequencies": [1.1, 7.3], "fade_in": 0.3}, 200.0),
    ("multi_sine", {"amplitudes": [0.01, 0.005], "wavelengths": [5.0, 0.9], "phases": [0.3, 1.0]}, 200.0),
    ("chirp", {"f0": 1.0, "f1": 15.0, "duration": 4.0, "start": 0.1, "method": "linear"}, 200.0),
    ("chirp", {"f0": 1.0, "f1": 15.0, "duration": 4.0, "method": "quadratic"}, 200.0),
    ("chirp", {"f0": 1.0, "f1": 15.0, "duration": 4.0, "method": "logarithmic", "taper": 0.5}, 200.0),
    ("chirp", {"f0": 1.0, "f1": 15.0, "duration": 4.0, "method": "hyperbolic"}, 200.0),
    ("iso8608", {"road_class": "C"}, 200.0),
    ("hac", {"surface": "dirt", "dx": 0.1}, 200.0),  # thesis Ch. 5's road
    ("hac", {"surface": "asphalt", "dx": 0.1}, 25_000.0),  # a long run: the periodic spline (seam at 20 km)
    ("profile", {"offset": 1.0}, 100.0),
    ("profile", {"fade_in": 0.0, "beyond_end": "repeat"}, 200.0),
]
SPLINE_ROADS = {"iso8608", "hac", "profile"}


def _road(name, params, distance, tmp_path):
    cls = ROADS.get(name)
    if name == "profile":
        params = {**params, "file": _profile_csv(tmp_path)}
    p = cls.Params.model_validate(params)
    ctx = RoadContext(duration=distance / V, distance=distance, wheelbase=0.0, mean_speed=V, dt=5e-4)
    return cls(p, np.random.default_rng(7), ctx)


def _times(distance):
    t0 = 0.0 if distance < 1000 else 19_990.0 / V  # the periodic road: across its seam
    return t0 + 0.000317 + np.arange(8000) * 0.000731  # 5.8 s, off any grid or shape edge


def test_every_registered_road_is_covered():
    assert {c[0] for c in CASES} == set(ROADS.names())


@pytest.mark.parametrize("name,params,distance", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_road_rate_is_the_time_derivative_of_the_height(name, params, distance, tmp_path):
    road = _road(name, params, distance, tmp_path)
    t = _times(distance)
    z = lambda tt: road.height(tt, V * tt, 0)  # noqa: E731 - a wheel driving at V
    fine = (z(t + H) - z(t - H)) / (2 * H)
    rate = road.rate(t, V * t, 0, 1.0, V)
    scale = np.max(np.abs(fine))
    if name == "flat":
        assert np.all(rate == 0) and scale == 0
        return
    assert scale > 1e-3  # the road moves over the samples (the test is not vacuous)
    err = np.max(np.abs(rate - fine)) / scale
    assert err < TOL, err
    old = (z(t + 1e-3) - z(t - 1e-3)) / 2e-3  # the former central difference at a 1 ms step
    old_err = np.max(np.abs(old - fine)) / scale
    assert old_err > TOL, old_err  # ... which this tolerance rejects (on the spline roads by 100-1000x)
    if name in SPLINE_ROADS:
        assert old_err > 50 * TOL, old_err


@pytest.mark.skipif("half_car" not in VEHICLES, reason="half car model not available")
@pytest.mark.parametrize("road", [{"type": "hac", "params": {"surface": "dirt", "dx": 0.1, "fade_in": 1.0}},
                                  {"type": "bump", "params": {"duration": 0.1, "start": 0.05}}])
def test_road_chunk_rate_follows_each_wheel_under_a_varying_speed(road):
    """The delivered rate includes the wheel's motion: ẋ = v(t), and for a temporal input under the rear wheel
    the corner time's rate v(t)/v(t_c) (≈ 1.14 here; taking 1 would fail)."""
    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    dt = 1e-5
    sc = parse_scenario({"vehicle": {"model": "half_car", "params": {"a": 1.2, "b": 1.6}},
                         "road": {**road, "speed": [[0.0, 15.0], [0.4, 23.0]]},
                         "sim": {"duration": 0.4, "dt": dt}})
    sim = Simulation([sc])
    z, zd = sim.road_chunk(0, sim.n_steps)[:2]
    fine = (z[0, 2:] - z[0, :-2]) / (2 * dt)  # error ~ (ω dt)²/6 < 1e-6 of the rate
    for c in range(z.shape[2]):
        scale = np.max(np.abs(fine[:, c]))
        assert scale > 1e-2
        assert np.max(np.abs(zd[0, 1:-1, c] - fine[:, c])) / scale < 1e-3


@pytest.mark.parametrize("name,params", [("multi_sine", {"amplitudes": [0.02, 0.01], "frequencies": [0.5, 1.2]}),
                                         ("half_sine", {"duration": 0.3}),
                                         ("chirp", {"f0": 1.0, "f1": 5.0, "duration": 2.0, "taper": 0.0})])
def test_rate_on_a_kink_is_the_mean_of_the_one_sided_derivatives(name, params, tmp_path):
    """A road starting with a slope at t = 0 has a kink on the first sample: the rate there is the mean of the
    one-sided derivatives (the limit of a central difference), not the right-hand one (which moved the Ch. 3
    adaptation's first controller sample by 2x); just after the edge it is the exact derivative."""
    road = _road(name, params, 200.0, tmp_path)
    right = road.rate(np.array([1e-9]), np.array([0.0]), 0, 1.0, V)[0]
    assert abs(right) > 1e-2
    assert road.rate(np.array([0.0]), np.array([0.0]), 0, 1.0, V)[0] == pytest.approx(0.5 * right, rel=1e-6)
