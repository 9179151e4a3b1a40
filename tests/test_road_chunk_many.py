""":meth:`System.road_chunk` evaluates the wheels of an ensemble together (grouped by road type, speed law, axle
and track; a closed-form road's cars in one array expression, :meth:`Road.height_slopes_many`) and must give
bit for bit the numbers of evaluating each wheel alone as it did before: ``road.height`` on the wheel's corner
time and distance, ``road.rate`` with the corner time's rate and the speed.  The ensembles below mix road
types, temporal and spatial sines with and without fade-in, shared road objects, two axles and a speed table,
so that a wrong grouping, a parameter given to the wrong car or a changed operation fails."""
from __future__ import annotations

import numpy as np
import pytest

from suspension_sim.config import parse_scenario
from suspension_sim.registry import VEHICLES
from suspension_sim.roads.base import RoadContext
from suspension_sim.roads.sine import Sine
from suspension_sim.simulation import Simulation


def _reference(sim, k0, k1):
    """road_chunk as it was: wheel by wheel, height and rate asked of each road separately."""
    n, nc = sim.plant.n, sim.plant.nc
    L = k1 - k0
    t = np.arange(k0 - 1, k1 + 1) * sim.dt
    z, zd = np.empty((n, L + 2, nc)), np.empty((n, L, nc))
    for i, (road, sp) in enumerate(zip(sim.roads, sim.speeds)):
        x, v = sp.distance(t), sp.speed(t[1:-1])
        for c in range(nc):
            back = sim.corner_back[i, c]
            xc = x - back
            if back == 0:
                tc, tc_rate = t, 1.0
            else:
                tc, tc_rate = sp.time_at(xc, t), sp.time_at_rate(xc[1:-1], t[1:-1])
            z[i, :, c] = road.height(tc, xc, sim.geom.tracks[c])
            zd[i, :, c] = road.rate(tc[1:-1], xc[1:-1], sim.geom.tracks[c], tc_rate, v)
    return z[:, 1:-1], zd


SINES = [{"amplitude": 0.02, "frequency": 1.3},
         {"amplitude": 0.011, "frequency": 0.7, "phase": 0.4, "start": 0.05},
         {"amplitude": 0.03, "frequency": 2.1, "fade_in": 0.15, "start": 0.02},
         {"amplitude": 0.015, "wavelength": 3.3, "phase": -0.3},
         {"amplitude": 0.025, "wavelength": 1.9, "fade_in": 1.2, "start": 0.5}]
OTHERS = [{"type": "iso8608", "params": {"road_class": "C"}},
          {"type": "multi_sine", "params": {"amplitudes": [0.01, 0.004], "frequencies": [1.1, 6.3]}},
          {"type": "bump", "params": {"length": 1.0, "start": 2.0, "repeat": 2}}]


def _scs(model, roads, speed, duration=0.3):
    return [parse_scenario({"name": f"r{i}", "vehicle": {"model": model},
                            "road": {**r, "speed": speed}, "sim": {"duration": duration, "dt": 5e-4}})
            for i, r in enumerate(roads)]


def _roads(n):
    rng = np.random.default_rng(4)
    out = [{"type": "sine", "params": SINES[i % len(SINES)]} for i in range(n)]
    for r in out[len(SINES):]:  # more cars: amplitudes and frequencies of their own
        r["params"] = {**r["params"], "amplitude": float(rng.uniform(0.005, 0.03))}
        key = "frequency" if "frequency" in r["params"] else "wavelength"
        r["params"][key] = float(r["params"][key] * rng.uniform(0.8, 1.2))
    return out


@pytest.mark.parametrize("model,speed", [("quarter_car", 20.0), ("quarter_car", [[0.0, 5.0], [0.3, 25.0]]),
                                         ("half_car", 17.0), ("half_car", [[0.0, 12.0], [0.2, 22.0]])])
def test_road_chunk_is_the_wheel_by_wheel_evaluation(model, speed):
    if model not in VEHICLES:
        pytest.skip(f"{model} not available")
    roads = _roads(12) + OTHERS + [OTHERS[0], {"type": "sine", "params": SINES[2]}]  # repeats: shared objects
    sim = Simulation(_scs(model, roads, speed))
    assert sim.roads[-5] is sim.roads[-2] and sim.roads[2] is sim.roads[-1]  # the same road, built once
    # a sine without fade-in at a constant speed is evaluated by the angle-addition recurrence along the steps
    # (Sine.height_slopes_many with a StepGrid): within 1e-13 of the amplitude (rate: of amplitude·k·speed);
    # every other wheel bit for bit
    rec = np.array([isinstance(r, Sine) and r.p.fade_in == 0 and sp.const is not None
                    for r, sp in zip(sim.roads, sim.speeds)])
    assert rec.any() == isinstance(speed, float) and not rec.all()
    for k0, k1 in [(0, 250), (250, 600)]:
        got, ref = sim.road_chunk(k0, k1), _reference(sim, k0, k1)
        assert got[0].shape == ref[0].shape and got[1].shape == ref[1].shape
        assert np.array_equal(got[0][~rec], ref[0][~rec]) and np.array_equal(got[1][~rec], ref[1][~rec])
        for a, b in zip(got, ref) if rec.any() else ():
            scale = np.abs(b[rec]).max()
            assert np.abs(a[rec] - b[rec]).max() <= 1e-13 * scale
            assert np.array_equal(a[rec] == 0, b[rec] == 0)  # the same edge: 0 before the start
        assert np.any(got[1] != 0) and not np.array_equal(got[0][0], got[0][1])
    # the compiled loop reads one step's road for all cars contiguously: no copy to make
    z = sim.road_chunk(0, 10)[0]
    assert np.ascontiguousarray(z.transpose(1, 0, 2)).base is not None


def test_sine_many_is_each_road_alone():
    ctx = RoadContext(duration=1.0, distance=20.0, wheelbase=0.0, mean_speed=20.0, dt=1e-3)
    roads = [Sine(Sine.Params(**p), None, ctx) for p in SINES * 3]
    t = np.linspace(-0.1, 1.0, 1101)
    x = 20.0 * t - 0.7
    many = Sine.height_slopes_many(roads, t, x)
    for k, r in enumerate(roads):
        zt, zx = r.slopes(t, x)
        for a, b in zip((r.height(t, x), zt, zx), (many[0][k], many[1][k], many[2][k])):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("params", [{"frequency": 3.7, "phase": 0.3, "start": 0.0123},
                                    {"wavelength": 2.9, "phase": -1.1, "start": 0.77}])
def test_sine_recurrence_is_the_closed_form_and_independent_of_the_chunks(params):
    """The recurrence (a rotation per step, re-anchored on exact sin/cos every 64 steps of the run) against
    sin/cos per sample over a long run (200 s at 0.5 ms, 2 wheels per car), and the same bits whichever chunks
    the steps are computed in (one step at a time as the envs ask, 2000-step chunks as the loops do)."""
    if "half_car" not in VEHICLES:
        pytest.skip("half_car not available")
    amp = 0.021
    sim = Simulation(_scs("half_car", [{"type": "sine", "params": {"amplitude": amp, **params}}], 23.0,
                          duration=200.0))
    road = sim.roads[0]
    k = 2 * np.pi * (params["frequency"] if "frequency" in params else 1 / params["wavelength"])
    for k0, k1 in [(0, 2000), (398000, 400000)]:
        z, zd = sim.road_chunk(k0, k1)
        rz, rzd = _reference(sim, k0, k1)
        # the closed form's own argument k·s + φ is rounded to an ulp of its size (~1e-12 rad at 200 s): the
        # two agree to that, plus the recurrence's ~1e-14
        arg = k * (k1 * sim.dt * (23.0 if "wavelength" in params else 1.0)) + 2.0
        tol = 1e-13 + 8 * np.finfo(float).eps * arg
        assert np.abs(z - rz).max() <= tol * amp and np.abs(zd - rzd).max() <= tol * amp * k * 23.0
        assert not np.array_equal(z[0, :, 0], z[0, :, 1])  # the rear wheel sees the road later
    ones = [sim.road_chunk(k, k + 1) for k in range(1990, 2140)]
    for j in (0, 1):
        joined = np.concatenate([c[j] for c in ones], axis=1)
        assert np.array_equal(joined, np.concatenate([sim.road_chunk(1990, 2000)[j], sim.road_chunk(2000, 2140)[j]],
                                                     axis=1))
    assert road.p.fade_in == 0


def test_a_road_class_without_the_grid_keyword_still_works():
    """A road class written before the ``grid`` keyword existed (its own height_slopes_many without it) is called
    without it, and gives its numbers."""
    from suspension_sim.roads.base import Road

    class OldSine(Sine):
        @classmethod
        def height_slopes_many(cls, roads, t, x, track=0):
            return Road.height_slopes_many.__func__(cls, roads, t, x, track)

    sim = Simulation(_scs("quarter_car", [{"type": "sine", "params": SINES[0]}] * 3, 20.0))
    sim.roads = [OldSine(r.p, None, r.ctx) for r in sim.roads]
    z, zd = sim.road_chunk(0, 300)
    ref = _reference(sim, 0, 300)
    assert np.array_equal(z, ref[0]) and np.array_equal(zd, ref[1])
