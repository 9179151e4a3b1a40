"""Compiled controller kernels (issue 7) against their numpy ``step``: each test runs a short closed loop in
Python (suspension_sim.compiled.testing.check_controller), replays every control step's readings through
the kernel, one car at a time, and compares commands and logged signals.

Laws built from + − × ÷ and comparisons only are required to match exactly (0.0).  Where the numpy law
uses a transcendental function or a BLAS matrix product, the kernel may round differently in the last
place; those tests allow 1e-12 relative to the largest magnitude compared and say why."""
import copy

import numpy as np
import pytest

from suspension_sim.compiled.testing import check_controller
from suspension_sim.config import parse_scenario, load_scenario
from suspension_sim.simulation import Simulation


def _quarter(controller, sensors, duration=0.5, road=None, **sim):
    return parse_scenario(dict(
        name="kernel_test",
        road=road or dict(type="sine", params={"frequency": 1.7, "amplitude": 0.02}),
        sensors=sensors,
        actuator=dict(type="ideal", params=dict(max_force=3000.0, time_constant=0.002)),
        controller=controller,
        sim={**dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001, seed=3), **sim},
    ))


def _python_run(sim):
    """The Python closed loop: per control step {t, readings, u, signals} (to check which branches occur)."""
    out = []
    readings = sim.start()
    while readings is not None:
        u = np.broadcast_to(np.asarray(sim.controller.step(sim.t, readings), dtype=float),
                            (sim.plant.n, sim.plant.nc)).copy()
        out.append(dict(t=sim.t, readings=readings, u=u,
                        signals={k: np.array(v, dtype=float) for k, v in sim.controller.signals().items()}))
        readings = sim.control_step(u)
    return out


def _check_sync(make_sim):
    """Drive a fresh controller with the first half of a Python run's readings through its kernel, write the
    kernel state back (kernel_sync), continue with the Python step: the commands and signals of the second
    half must equal the Python run's exactly."""
    run = _python_run(make_sim())
    ctrl = make_sim().controller
    p, st = ctrl.kernel_data()
    names = list(ctrl.ctx.sensors)
    u = np.zeros(ctrl.ctx.n_corners)
    half = len(run) // 2
    for r in run[:half]:
        for i in range(ctrl.ctx.n_cars):
            yi = np.concatenate([np.asarray(r["readings"][nm], float).reshape(ctrl.ctx.n_cars, -1)[i] for nm in names])
            ctrl.kernel(r["t"], yi, p[i], st[i], u)
    ctrl.kernel_sync(st)
    for r in run[half:]:
        np.testing.assert_array_equal(np.broadcast_to(ctrl.step(r["t"], r["readings"]), r["u"].shape), r["u"])
        for k, v in ctrl.signals().items():
            np.testing.assert_array_equal(v, r["signals"][k])
    return True


# passive / skyhook ---------------------------------------------------------------------------------------

# check_controller concatenates the readings of the declared sensors and cannot handle none: the runs of
# controllers that read nothing declare one unused sensor
UNUSED = [dict(type="travel")]


def test_passive_kernel_is_zero():
    sims = [Simulation([_quarter(dict(type="passive"), [dict(type="corner_body_vel")])]),
            Simulation([_quarter(dict(type="passive"), UNUSED, duration=0.2)] * 3)]
    for sim in sims:
        assert check_controller(sim) == 0.0


SKY_SENSORS = [dict(type="travel_rate", noise_std=0.01), dict(type="corner_body_vel", noise_std=0.005),
               dict(type="wheel_vel", noise_std=0.01)]


def test_skyhook_kernel_single_car_exact():
    sc = _quarter(dict(type="skyhook", params=dict(c_sky=2500.0)), [dict(type="corner_body_vel", noise_std=0.002)])
    assert check_controller(Simulation([sc])) == 0.0


def test_skyhook_kernel_ensemble_groundhook_semi_active_exact():
    """Three cars with different gains, one without groundhook and one without the semi-active clip; noisy
    travel rate so that both sides of the clip occur."""
    scs = [_quarter(dict(type="skyhook", params=dict(c_sky=cs, c_ground=cg, semi_active=semi)), SKY_SENSORS)
           for cs, cg, semi in ((2500.0, 0.0, True), (1200.0, 800.0, False), (4000.0, 300.0, True))]
    run = _python_run(Simulation(scs))
    u = np.array([r["u"][:, 0] for r in run])
    vr = np.array([r["readings"]["travel_rate"][:, 0] for r in run])
    for i in (0, 2):  # both branches of the clip
        assert np.sum(u[:, i] == 0.0) > 20 and np.sum(u[:, i] != 0.0) > 20
        assert np.all(u[:, i] * vr[:, i] <= 0)
    assert np.sum(u[:, 1] * vr[:, 1] > 0) > 20  # no clip on the second car
    assert check_controller(Simulation(scs)) == 0.0


def test_skyhook_kernel_groundhook_without_clip_half_car_exact():
    sc = parse_scenario(dict(
        vehicle=dict(model="half_car"), road=dict(type="sine", params={"frequency": 1.2, "amplitude": 0.02}, speed=10),
        sensors=[dict(type="corner_body_vel"), dict(type="wheel_vel")],
        controller=dict(type="skyhook", params=dict(c_sky=2000.0, c_ground=500.0)),
        sim=dict(duration=0.3, dt=0.0005, control_dt=0.001, log_dt=0.001)))
    assert check_controller(Simulation([sc, sc.model_copy(deep=True)])) == 0.0


# open loop -----------------------------------------------------------------------------------------------

def _rig(vehicle="quarter_car", duration=0.5, **params):
    return parse_scenario(dict(
        vehicle=dict(model=vehicle), road=dict(type="flat"), sensors=UNUSED,
        controller=dict(type="open_loop", params=params),
        sim=dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001)))


def _ensemble(*param_sets, **kw):
    return Simulation([_rig(**kw, **ps) for ps in param_sets])


def test_open_loop_kernel_exact_signals():
    """constant, step/pulse (before, during, after), PRBS (shared and per corner) and tables (linear and
    zero-order hold, one column or one per corner, tables of different lengths, before/inside/after the
    table): + − × ÷ and comparisons only, so exact."""
    assert check_controller(_ensemble(dict(signal="constant", amplitude=20.0, offset=5.0),
                                      dict(signal="constant", amplitude=[1.0, -3.0], offset=[0.5, 0.0]),
                                      dict(signal="constant", amplitude=-7.0), vehicle="half_car", duration=0.1)) == 0.0
    assert check_controller(_ensemble(dict(signal="step", amplitude=100.0, offset=-1.0, start=0.1, stop=0.3),
                                      dict(signal="step", amplitude=-40.0, offset=2.0, start=0.25, stop=0.26),
                                      dict(signal="step", amplitude=10.0, offset=0.0, start=0.0, stop=0.45))) == 0.0
    assert check_controller(_ensemble(dict(signal="step", amplitude=3.0, start=0.2))) == 0.0  # no stop
    prbs = (dict(signal="prbs", amplitude=7.0, nbits=4, hold=0.004, seed=3, start=0.01),
            dict(signal="prbs", amplitude=2.0, nbits=4, hold=0.002, seed=5, offset=1.0),
            dict(signal="prbs", amplitude=3.0, nbits=4, seed=9, stop=0.3))  # cars with and without stop and hold
    u = np.array([s["u"][:, 0] for s in _python_run(_ensemble(*prbs))])
    assert set(np.unique(u[-10:, 0])) == {-7.0, 7.0} and set(np.unique(u[-10:, 1])) == {-1.0, 3.0}
    assert np.all(u[-10:, 2] == 0.0)  # stopped
    assert check_controller(_ensemble(*prbs)) == 0.0
    assert check_controller(_ensemble(dict(signal="prbs", amplitude=[7.0, 1.0], nbits=5, seed=1, independent=True),
                                      dict(signal="prbs", amplitude=4.0, nbits=5, seed=2, independent=True),
                                      dict(signal="prbs", amplitude=4.0, nbits=5, seed=3, independent=True, hold=0.005),
                                      vehicle="half_car", duration=0.2)) == 0.0


@pytest.fixture
def tables(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("time,force,front,rear\n0,0,1,2\n0.05,10,-1,3\n0.1,-5,4,4\n0.2,20,0,1\n0.3,0,2,-2\n")
    b.write_text("time,force,front,rear\n0,3,0,0\n0.1,-3,1,1\n0.15,1,2,0\n")
    return str(a), str(b)


def test_open_loop_kernel_exact_tables(tables):
    a, b = tables
    for interp in ("linear", "previous"):
        assert check_controller(_ensemble(dict(signal="table", file=a, column="force", interpolation=interp, start=0.05),
                                          dict(signal="table", file=b, column="force", interpolation=interp,
                                               amplitude=2.0, offset=1.0),
                                          dict(signal="table", file=a, column="force", interpolation=interp,
                                               start=0.1, stop=0.35), duration=0.45)) == 0.0
        assert check_controller(_ensemble(dict(signal="table", file=a, column=["front", "rear"], interpolation=interp),
                                          dict(signal="table", file=b, column=["front", "rear"], interpolation=interp,
                                               start=0.02),
                                          dict(signal="table", file=a, column=["front", "rear"], interpolation=interp, offset=[0.0, 2.0],
                                               amplitude=[1.0, -1.0]),
                                          vehicle="half_car", duration=0.4)) == 0.0


# the laws below call exp/sin/cos/log/pow, evaluated by numpy's own (SIMD) routines in the reference and by
# the C library in the kernel (on this machine they differ in the last bit for ~3-6 % of arguments), or sum
# in another order than numpy's BLAS/einsum: allowed 1e-12 of the command's bound (open loop) or, per
# quantity, of its largest magnitude over the run (_replay, _assert_close)
REL = 1e-12


def _replay(sim):
    """check_controller, per quantity: run ``sim`` in Python and a fresh copy of its controller's kernel on the
    same readings; return the Python run (as _python_run) and {quantity: (largest difference, largest
    magnitude)} for the command ("u") and every kernel signal."""
    kn = copy.deepcopy(sim.controller)
    kn.reset()
    p, st = kn.kernel_data()
    sig = kn.kernel_signals()
    names, n = list(kn.ctx.sensors), kn.ctx.n_cars
    out = np.zeros(kn.ctx.n_corners)
    stats = {}

    def acc(name, ref, got):
        d, m = stats.get(name, (0.0, 0.0))
        stats[name] = (max(d, float(np.max(np.abs(ref - got)))), max(m, float(np.max(np.abs(ref)))))

    run = _python_run(sim)
    for r in run:
        for i in range(n):
            yi = np.concatenate([np.asarray(r["readings"][nm], float).reshape(n, -1)[i] for nm in names])
            kn.kernel(r["t"], yi, p[i], st[i], out)
            acc("u", r["u"][i], out)
        for name, (a, b) in sig.items():
            acc(name, np.asarray(r["signals"][name], float).reshape(n, -1), st[:, a:b])
    return run, stats


def _assert_close(stats, rel=REL):
    """Every quantity within ``rel`` of its largest magnitude over the run."""
    bad = {k: v for k, v in stats.items() if not v[0] <= rel * v[1]}
    assert not bad, bad


def test_open_loop_kernel_sine_multisine_fade():
    bound = 50.0 + 3.0
    assert check_controller(_ensemble(dict(signal="sine", amplitude=50.0, frequency=3.0, phase=0.4, start=0.1,
                                           fade_in=0.2),
                                      dict(signal="sine", amplitude=20.0, frequency=7.0, offset=3.0, stop=0.4),
                                      dict(signal="sine", amplitude=5.0, frequency=1.0, start=0.05, fade_in=0.0))
                            ) <= REL * bound
    # 4 lines (sequential sum) and 11 lines (numpy's pairwise sum with 8 accumulators)
    f4, f11 = [1.0, 2.0, 3.5, 5.0], [1.0 + 1.3 * i for i in range(11)]
    a4 = [1, 0.5, 0.2, 2]
    assert check_controller(_ensemble(dict(signal="multisine", frequencies=f4, amplitudes=a4, amplitude=2.0),
                                      dict(signal="multisine", frequencies=f4, amplitudes=a4, amplitude=3.0, start=0.1),
                                      dict(signal="multisine", frequencies=f4, amplitudes=a4, fade_in=0.1))
                            ) <= REL * 3.0 * 2 * 4
    assert check_controller(_ensemble(dict(signal="multisine", frequencies=f4, phases="zero"), duration=0.2)
                            ) <= REL * 4
    assert check_controller(_ensemble(dict(signal="multisine", frequencies=f11, amplitude=2.0, phases="random", seed=1),
                                      dict(signal="multisine", frequencies=f11, amplitude=1.0, phases="random", seed=2),
                                      dict(signal="multisine", frequencies=f11, amplitude=4.0, phases="random", seed=3,
                                           stop=0.3))
                            ) <= REL * 4.0 * 11


@pytest.mark.parametrize("method", ["linear", "quadratic", "logarithmic", "hyperbolic"])
def test_open_loop_kernel_chirp(method):
    assert check_controller(_ensemble(dict(signal="chirp", amplitude=3.0, f0=0.5, f1=20.0, t1=0.3, method=method),
                                      dict(signal="chirp", amplitude=1.0, f0=5.0, f1=2.0, t1=0.2, method=method,
                                           phase=0.3, start=0.05),
                                      dict(signal="chirp", amplitude=2.0, f0=4.0, f1=4.0, t1=0.2, method=method,
                                           fade_in=0.1), duration=0.3)) <= REL * 3.0


def test_open_loop_random_has_no_kernel_and_runs():
    from suspension_sim.controllers.open_loop import OpenLoop
    from suspension_sim.compiled.loop import plan

    sim = _ensemble(dict(signal="random", amplitude=1.0), duration=0.05)
    assert isinstance(sim.controller, OpenLoop) and type(sim.controller).kernel is None
    assert plan(sim)[0] != "full"  # the compiled loop returns to Python for this controller
    r = sim.run()[0]
    assert r.ts["command"].std() > 0.5
    assert type(_ensemble(dict(signal="sine", amplitude=1.0, frequency=1.0)).controller).kernel is not None


def test_pairwise_sums_are_numpys():
    from suspension_sim.compiled.numpy_order import pairwise_sum

    rng = np.random.default_rng(0)
    for n in (1, 5, 7, 8, 9, 16, 17, 127, 128, 129, 200, 513, 1029, 5000):
        a = rng.standard_normal((2, n)) * 10.0 ** rng.uniform(-3, 3, (2, n))
        ref = np.sum(a, axis=1)
        for i in range(2):
            assert pairwise_sum(np.ascontiguousarray(a[i]), 0, n) == ref[i]
            assert pairwise_sum(np.concatenate([[9.0, 9.0], a[i]]), 2, n) == ref[i]  # at an offset


def test_open_loop_kernel_long_multisine():
    f = list(np.linspace(0.5, 40.0, 150))
    assert check_controller(_ensemble(dict(signal="multisine", frequencies=f, amplitude=0.1),
                                      dict(signal="multisine", frequencies=f, amplitude=0.2, start=0.05),
                                      dict(signal="multisine", frequencies=f, amplitude=0.3), duration=0.1)
                            ) <= REL * 0.3 * 150


# Kim -----------------------------------------------------------------------------------------------------

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _from_file(name, duration, road=None, **params):
    sc = load_scenario(ROOT / "scenarios" / name)
    sc.variants = {}
    sc.sim.duration = duration
    sc.outputs.plots = False
    sc = sc.model_copy(deep=True)
    sc.controller.params.update(params)
    sc.road.params.update(road or {})
    return sc


def test_kim_kernel_exact():
    """Fig. 2 (with dF_d/dt, rate prediction), Fig. 3 (without; literal law, load-cell force sensor,
    adaptation off), and a car whose a3 estimate starts far too low so that the ĝ floor is active, with
    larger adaptation gains: + − × ÷ sqrt and comparisons only, so exact."""
    A3 = 5.176e5
    g = dict(gain_a1=1e-10, gain_a2=1e-10, gain_a3=1e-10)  # the scenario's estimates and gains pinned here
    cases = [dict(k_d=10, use_fd_dot=True, rate_prediction=0.000193, a2=15.125e9, a3=A3, **g),
             dict(k_d=10, use_fd_dot=False, rate_prediction=0.0, force_sensor="actuator_force", adaptive=False,
                  a2=15.125e9, a3=A3, **g),
             dict(k_d=1000, use_fd_dot=True, a3=0.02 * A3, a2=0.9 * 15.125e9,
                  **{**g, "gain_a1": 1e-8, "gain_a2": 1e-8})]
    sim = Simulation([_from_file("kim_fig2.yaml", 0.3, **c) for c in cases])
    # the ĝ floor is hit by car 3 only, and the spool moves both ways (both signs in sqrt|P_s − sgn(X_V)x/A_p|)
    run = _python_run(sim)
    c = sim.controller
    g_min = (c.p.g_min_fraction * A3 * np.sqrt(c.p.supply_pressure))[:, 0]
    floored = []
    for prev, r in zip(run[:-1], run[1:]):
        x, xv = r["readings"]["hydraulic_force"][:, 0], r["readings"]["spool_position"][:, 0]
        sq = np.sqrt(np.abs(c.p.supply_pressure[:, 0] - np.sign(xv) * x / c.p.area[:, 0]))
        floored.append(prev["signals"]["a3_hat"][:, 0] * sq < g_min)
    floored = np.array(floored)
    assert not np.any(floored[:, 0]) and np.mean(floored[:, 2]) > 0.5
    xv = np.array([r["readings"]["spool_position"] for r in run])
    assert np.any(xv > 0) and np.any(xv < 0)
    assert abs(run[-1]["signals"]["a2_hat"][2, 0] / (0.9 * 15.125e9) - 1) > 1e-6  # adapting
    assert np.all(run[-1]["signals"]["a2_hat"][1] == 15.125e9)  # not adapting
    assert check_controller(Simulation([_from_file("kim_fig2.yaml", 0.3, **c) for c in cases])) == 0.0
    assert check_controller(Simulation([_from_file("kim_fig2.yaml", 0.1)])) == 0.0


def test_kim_kernel_sync():
    assert _check_sync(lambda: Simulation([_from_file("kim_fig2.yaml", 0.04)]))


# Toscano & Dumas -----------------------------------------------------------------------------------------

def test_toscano_kernel_two_rule_ensemble_exact():
    """The paper's two-rule triangles, three cars with different gains, initial estimates and masses
    (one car with a given M, the others the static load), and Δx, Δv ranges (ensemble-wide in the law)
    small enough that the triangle pair saturates at 0 on both sides."""
    rng = dict(range_dx=0.002, range_dv=0.02)
    cases = [dict(**rng), dict(k_ref=12000.0, b_ref=800.0, alpha=50.0, lambda_k=3e12, lambda_b=5e10, beta_k0=15000.0,
                               beta_b0=1500.0, **rng),
             dict(alpha=300.0, body_mass=250.0, lambda_k=0.0, **rng)]
    sim = Simulation([_from_file("toscano_constant.yaml", 0.5, **c) for c in cases])
    run = _python_run(sim)
    assert np.all(np.isfinite(sim.controller.M))
    dx = -np.array([r["readings"]["travel"][:, 0] for r in run])
    dv = -np.array([r["readings"]["travel_rate"][:, 0] for r in run])
    assert dx.max() > 0.002 and dx.min() < -0.002 and dv.max() > 0.02 and dv.min() < -0.02
    assert check_controller(Simulation([_from_file("toscano_constant.yaml", 0.5, **c) for c in cases])) == 0.0


def _toscano_half(membership, duration=0.4, **params):
    return parse_scenario(dict(
        vehicle=dict(model="half_car"), road=dict(type="sine", params={"frequency": 1.5, "amplitude": 0.03}, speed=10),
        sensors=[dict(type="travel"), dict(type="corner_body_vel"), dict(type="travel_rate"), dict(type="actuator_force")],
        actuator=dict(type="ideal", params=dict(time_constant=0.003)),
        controller=dict(type="toscano_dumas", params=dict(membership=membership, n_rules_k=5, n_rules_b=9,
                                                          range_dx=0.015, range_dv=0.2, **params)),
        sim=dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001)))


def test_toscano_kernel_grid_triangles_half_car_exact():
    """5 and 9 triangles on a grid (9: numpy's 8-accumulator pairwise sum), ranges exceeded (end triangles
    held), measured force in the estimator, two corners, three cars."""
    scs = [_toscano_half("triangular", force_sensor="actuator_force"),
           _toscano_half("triangular", force_sensor="actuator_force", lambda_k=5e11, beta_k0=1000.0),
           _toscano_half("triangular", force_sensor="actuator_force", alpha=80.0, body_mass=230.0)]
    run = _python_run(Simulation(scs))
    dx = -np.array([r["readings"]["travel"] for r in run])
    dv = -np.array([r["readings"]["travel_rate"] for r in run])
    assert dx.max() > 0.015 and dx.min() < -0.015 and dv.max() > 0.2 and dv.min() < -0.2
    assert check_controller(Simulation(scs)) == 0.0


def test_toscano_kernel_gaussian():
    """Gaussian memberships call exp: numpy's and the C library's may differ in the last bit; the error then
    passes through the basis normalisation and the estimates (≈ ulps of the command)."""
    scs = [_toscano_half("gaussian"), _toscano_half("gaussian", lambda_b=1e11), _toscano_half("gaussian", k_ref=5000.0)]
    _assert_close(_replay(Simulation(scs))[1])


def test_toscano_kernel_sync():
    assert _check_sync(lambda: Simulation([_toscano_half("triangular", duration=0.05, force_sensor="actuator_force"),
                                           _toscano_half("triangular", duration=0.05, beta_b0=100.0,
                                                         force_sensor="actuator_force")]))


# Fallah --------------------------------------------------------------------------------------------------

FALLAH_REASON = """the numpy law sums the differentiator by tensordot (OpenBLAS, FMA kernels) and the switching
function by einsum, in orders of their own, and calls exp: last-bit differences, which do not accumulate
(the integrators see only exactly reproduced quantities)"""


def test_fallah_kernel_full_car_bump():
    """Full car over the bump, three cars: the paper's law, a sigmoid shifted beyond the ±500 clip both
    ways (full force up and down) and a steeper one; a short mean window so that the moving-mean ring buffers
    wrap around during the run.  """ + FALLAH_REASON
    cases = [dict(mean_window=0.1), dict(mean_window=0.1, c=600.0, a=8.0), dict(mean_window=0.1, c=-600.0, f_max=3000.0)]
    def make():
        return Simulation([_from_file("fallah_bump.yaml", 0.6, road=dict(start=0.5), **c) for c in cases])
    run, stats = _replay(make())
    u = np.array([r["u"] for r in run])
    assert u[:, 0].min() < -500 and u[:, 0].max() > 500  # the bump is crossed
    assert np.all(u[:, 1] == -6000.0) and np.all(u[:, 2] == 3000.0)  # clipped sigmoid argument
    _assert_close(stats)


def test_fallah_kernel_no_gyro_mixed_position_mean_removal():
    def make(cases=((2.0, False), (4.0, True), (8.0, False))):
        scs = []
        for a, pmr in cases:
            scs.append(parse_scenario(dict(
                vehicle=dict(model="half_car"), road=dict(type="bump", params=dict(preset="fallah"), speed=9.7222),
                sensors=[dict(type="travel"), dict(type="body_acc")], actuator=dict(type="ideal", params=dict(max_force=6000)),
                controller=dict(type="fallah", params=dict(a=a, gyro_sensor=None, position_mean_removal=pmr,
                                                           mean_window=0.05)),
                sim=dict(duration=0.4, dt=0.0005, control_dt=0.001, log_dt=0.001))))
        return Simulation(scs)
    run, stats = _replay(make())
    _assert_close(stats)
    for k, case in ((0, (2.0, False)), (1, (4.0, True))):  # each car as if alone (the flag is per car)
        solo = _python_run(make((case,)))
        np.testing.assert_array_equal(np.array([r["signals"]["zs_hat"][k] for r in run]),
                                      np.array([r["signals"]["zs_hat"][0] for r in solo]))


def test_fallah_kernel_sync():
    assert _check_sync(lambda: Simulation([_from_file("fallah_bump.yaml", 0.15, mean_window=0.03)]))


# Lin & Kanellakopoulos -----------------------------------------------------------------------------------

def _lin(duration=0.35, start=0.02, height=0.08, **params):
    sc = _from_file("lin_fig4.yaml", duration, road=dict(start=start, height=height), **params)
    sc.sim.dt = sc.sim.control_dt = 0.0001
    return sc


def test_lin_kernel_generated_code_is_up_to_date():
    """The kernel's copy of the symbolic derivation (between the GENERATED markers) is what kernel_source()
    produces from the current derivation."""
    import suspension_sim.controllers.lin_kanellakopoulos as lk

    text = (ROOT / "controllers" / "lin_kanellakopoulos.py").read_text()
    a, b = "# --- GENERATED by kernel_source(), do not edit ---\n", "# --- END GENERATED ---\n"
    assert text[text.index(a) + len(a):text.index(b)] == lk.kernel_source()


def test_lin_kernel_exact_inside_the_filter_threshold():
    """Three cars (adaptive, non-adaptive, other gains) over a 3 cm bump: |η| stays below m1, where the law
    uses + − × ÷, sqrt and the C library's pow (as the reference's math-module evaluation does): exact."""
    cases = [dict(), dict(adaptive=False), dict(c1=150.0, c4=250.0, adaptation_gain=80.0, b3=0.02)]
    make = lambda: Simulation([_lin(height=0.03, **c) for c in cases])  # noqa: E731
    run = _python_run(make())
    assert max(np.abs(r["readings"]["travel"]).max() for r in run) < 0.055
    th = np.array([r["signals"]["theta_hat"][:, 0] for r in run])
    assert th[-1, 0] != th[1, 0] and th[-1, 1] == th[1, 1]
    assert check_controller(make()) == 0.0


def test_lin_kernel_beyond_the_filter_threshold():
    """The 8 cm bump of Fig. 4 takes |η| beyond m1 (φ ≠ 0): the reference then evaluates η⁴, η³ and the
    filter's exp by numpy's own routines, the kernel by the C library's.  The last-bit differences are
    carried on by the filter state and θ̂ and amplified by the law (z_i ≈ 1e-11 relative at single steps; the
    command, up to 1e16 where the spool demand is absurd and the actuator clips it, up to ≈ 1e-6 relative
    near its zero crossings); against each quantity's largest magnitude over the run they stay < 1e-12."""
    run, stats = _replay(Simulation([_lin(), _lin(adaptive=False)]))
    assert max(np.abs(r["signals"]["phi"]).max() for r in run) > 0
    _assert_close(stats)


def test_lin_kernel_large_ensemble_numpy_evaluation():
    """More than 8 corners: the reference evaluates the derivation with numpy (squares as v·v); inside the
    threshold still exact."""
    make = lambda: Simulation([_lin(duration=0.1, height=0.03, c2=180.0 + 5 * i) for i in range(9)])  # noqa: E731
    assert check_controller(make()) == 0.0


def test_lin_kernel_sync():
    assert _check_sync(lambda: Simulation([_lin(duration=0.02)]))


# the kernels inside the compiled loop ----------------------------------------------------------------------

LOOP_CASES = {
    "skyhook": lambda: [_quarter(dict(type="skyhook", params=dict(c_sky=cs, c_ground=cg, semi_active=semi)), SKY_SENSORS,
                                 duration=0.3) for cs, cg, semi in ((2500.0, 0.0, True), (1200.0, 800.0, False))],
    "open_loop": lambda: [_rig(signal="multisine", frequencies=[1.0, 2.0, 5.0], amplitude=a, fade_in=0.1, duration=0.3)
                          for a in (50.0, 80.0)],
    "toscano_dumas": lambda: [_toscano_half("triangular", duration=0.3, force_sensor="actuator_force", k_ref=k)
                              for k in (10000.0, 8000.0)],
    "lin_kanellakopoulos": lambda: [_lin(duration=0.1, height=0.03), _lin(duration=0.1, height=0.03, adaptive=False)],
}


@pytest.mark.parametrize("name", list(LOOP_CASES))
def test_compiled_loop_equals_python_loop(name, monkeypatch):
    """Simulation.run with the compiled loop (the kernel inlined, its state from kernel_data, written back
    by kernel_sync) gives the Python loop's time series bit for bit."""
    from suspension_sim.compiled.loop import plan

    sim = Simulation(LOOP_CASES[name]())
    assert plan(sim)[0] == "full"
    compiled = sim.run()
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    python = Simulation(LOOP_CASES[name]()).run()
    for a, b in zip(compiled, python):
        assert list(a.ts.columns) == list(b.ts.columns)
        np.testing.assert_array_equal(a.ts.to_numpy(float), b.ts.to_numpy(float))
