"""The compiled loop (suspension_sim.compiled) against the Python loop of simulation.py.

Every scenario file, shortened, runs both ways; the time series and metrics must agree.  Most combinations
are bit-identical (the kernels repeat the numpy methods' operations in order); kernels that call tanh, exp or
pow may differ from numpy's vectorised versions by an ulp, which the dynamics carry forward, so the
comparison allows 1e-9 of each channel's range (far below any physical meaning, far above an ulp)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import parse_scenario, read_yaml
from suspension_sim.errors import SimulationDiverged
from suspension_sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
# model files of the discrepancy workflow (no road) and the sweep file are not runnable scenarios
SCENARIOS = sorted(p for p in (ROOT / "scenarios").glob("*.yaml")
                   if p.name != "sweep_example.yaml" and not p.name.startswith("diagnose_"))
# events moved into the shortened run, so that it compares motion rather than round-off around rest
EARLIER = {"fallah_bump": {"road.params.start": 1.0}}


def _raw(path: Path, duration: float) -> dict:
    raw = read_yaml(path)
    raw.pop("variants", None)
    raw.setdefault("sim", {})["duration"] = duration
    raw.setdefault("outputs", {})["plots"] = False
    for key, value in EARLIER.get(path.stem, {}).items():
        *parents, leaf = key.split(".")
        node = raw
        for k in parents:
            node = node.setdefault(k, {})
        node[leaf] = value
    return raw


def _run(scs, compiled: bool, monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    sim = Simulation(scs)
    res = sim.run()
    return sim, res


def _assert_same(ra, rb, rel=1e-9):
    assert list(ra.ts.columns) == list(rb.ts.columns)
    for col in ra.ts.columns:
        a, b = ra.ts[col].to_numpy(), rb.ts[col].to_numpy()
        assert np.array_equal(np.isnan(a), np.isnan(b)), col
        scale = max(1.0, float(np.nanmax(np.abs(a), initial=0.0)))
        diff = float(np.nanmax(np.abs(a - b), initial=0.0))
        assert diff <= rel * scale, f"{col}: {diff:.3g}"
    assert ra.metrics.keys() == rb.metrics.keys()
    for k, v in ra.metrics.items():
        w = rb.metrics[k]
        rms = ra.metrics.get(k.replace("_crest", "_rms"), 1.0) if k.endswith("_crest") else 1.0
        if rms < 1e-9:
            continue  # the crest factor (peak / rms) of a channel that is round-off (e.g. heave in a symmetric DLC)
        assert (np.isnan(v) and np.isnan(w)) or abs(v - w) <= rel * max(1.0, abs(v)), k


@pytest.mark.parametrize("path", SCENARIOS, ids=[p.stem for p in SCENARIOS])
def test_scenario_files_agree(path, monkeypatch):
    sc = parse_scenario(_raw(path, 0.3), str(path))

    def both():
        out = {}
        for compiled in (True, False):
            try:
                out[compiled] = _run([sc], compiled, monkeypatch)
            except SimulationDiverged as e:
                out[compiled] = e
        return out

    runs = both()
    stops = {k: v for k, v in runs.items() if isinstance(v, SimulationDiverged)}
    if stops:
        # a default law that runs away (the thesis's printed laws, e.g. thesis_ch6_random's at 0.09 s) must stop both
        # loops at the same time and in the same state; they are then compared up to the log step before the stop
        assert len(stops) == 2 and str(stops[True]) == str(stops[False]), {k: str(v) for k, v in stops.items()}
        sc.sim.duration = float(np.floor(stops[True].time / sc.sim.log_dt) * sc.sim.log_dt - sc.sim.log_dt)
        assert sc.sim.duration > 0.05, stops[True].time
        runs = both()
    (sim_c, rc), (sim_p, rp) = runs[True], runs[False]
    assert sim_p.loop == "python"
    _assert_same(rp[0], rc[0])


def test_quickstart_runs_fully_compiled_and_bit_identical(monkeypatch):
    sc = parse_scenario(_raw(ROOT / "scenarios" / "quickstart.yaml", 1.0))
    sim_c, rc = _run([sc], True, monkeypatch)
    _, rp = _run([sc], False, monkeypatch)
    assert sim_c.loop == "full", sim_c.loop_reason
    pd_a, pd_b = rp[0].ts, rc[0].ts
    assert pd_a.equals(pd_b)  # bit for bit, every column
    assert rp[0].metrics == rc[0].metrics


def _bench_like(n, **over):
    rng = np.random.default_rng(3)
    out = []
    for i in range(n):
        raw = {
            "name": f"car{i}",
            "vehicle": {"model": "quarter_car",
                        "params": {"sprung_mass": float(rng.uniform(250, 330))},
                        "effects": [{"type": "quadratic_damping", "params": {"c_v": float(rng.uniform(100, 400))}},
                                    {"type": "bump_stop", "params": {"gap": 0.02, "stiffness": 40000.0}}]},
            "road": {"type": "sine", "params": {"amplitude": float(rng.uniform(0.01, 0.03)), "frequency": 1.3},
                     "speed": 20.0},
            "sensors": [{"type": "corner_body_vel", "noise_std": 0.002, "delay": 0.002, "rate": 500.0,
                         "quantization": 1e-4},
                        {"type": "travel"}, {"type": "actuator_force"}],
            "actuator": {"type": "ideal", "params": {"time_constant": 0.003, "max_force": 1500.0}},
            "controller": {"type": "skyhook", "params": {"c_sky": float(rng.uniform(1500, 3000))}},
            "sim": {"duration": 0.6, "seed": i},
        }
        for k, v in over.items():
            raw[k] = v
        out.append(parse_scenario(raw))
    return out


def test_ensemble_with_sensor_pipeline_is_bit_identical(monkeypatch):
    scs = _bench_like(3)
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "full", sim_c.loop_reason
    for a, b in zip(rp, rc):
        assert a.ts.equals(b.ts)
        assert a.metrics == b.metrics
    # and each car alone equals the car inside the ensemble
    _, alone = _run([scs[1]], True, monkeypatch)
    assert alone[0].ts.equals(rc[1].ts)


def test_every_compiled_sensor_field_reads_what_the_python_pipeline_reads(monkeypatch):
    """Each PlantState field a sensor reads has its own code in the generated loop (compiled.loop._FIELD_CODE):
    every one of them, on a half car (pitch, two corners, tires), equals the Python loop bit for bit."""
    from suspension_sim.compiled.loop import FIELDS

    plain = ["actuator_force", "body_acc", "body_pos", "body_vel", "corner_body_acc", "corner_body_pos",
             "corner_body_vel", "road", "road_vel", "tire_force", "travel", "travel_rate", "wheel_acc", "wheel_pos",
             "wheel_vel"]
    sensors = [{"name": n, "type": n} for n in plain]
    sensors += [{"name": f"{n}_mean", "type": n, "params": {"sampling": "period_mean"}}
                for n in ("body_acc", "corner_body_acc", "wheel_acc")]
    sensors += [{"name": "pressure", "type": "actuator_state", "params": {"state": "load_pressure"}},
                {"name": "noisy", "type": "tire_force", "noise_std": 1.0, "delay": 0.002}]  # the ring buffer's path
    sc = parse_scenario({"name": "fields", "vehicle": {"model": "half_car"},
                         "road": {"type": "sine", "params": {"frequency": 2.0, "amplitude": 0.02}, "speed": 10.0},
                         "sensors": sensors, "actuator": {"type": "hydraulic"}, "controller": {"type": "passive"},
                         "sim": {"duration": 0.3, "control_dt": 0.002}, "outputs": {"plots": False}})
    sim_c, rc = _run([sc], True, monkeypatch)
    _, rp = _run([sc], False, monkeypatch)
    assert sim_c.loop == "full", sim_c.loop_reason
    assert len(set(FIELDS) - {"corner_body_acc_mean", "body_acc_mean", "wheel_acc_mean"} - set(plain)) == 1  # actuator_state
    cols = [c for c in rp[0].ts.columns if c.startswith("sensor.")]
    assert len(cols) == 40 and sum(float(np.abs(rp[0].ts[c]).max()) > 0 for c in cols) >= 38
    assert rp[0].ts.equals(rc[0].ts)


def test_hybrid_loop_with_full_state_access(monkeypatch):
    scs = _bench_like(2, controller={"type": "skyhook", "params": {"c_sky": 2000.0}, "full_state": True})
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "hybrid" and "full-state" in sim_c.loop_reason
    for a, b in zip(rp, rc):
        assert a.ts.equals(b.ts)


def test_python_fallback_switch(monkeypatch):
    sc = _bench_like(1)[0]
    sim, _ = _run([sc], False, monkeypatch)
    assert sim.loop == "python" and "SUSPENSION_SIM_COMPILED" in sim.loop_reason


def test_rk4_compiled_is_bit_identical(monkeypatch):
    """RK4 keeps the road plates (driven by a force within the stages) and reads the acceleration from
    mj_forwardSkip: the compiled loop does the same calls."""
    raw = _raw(ROOT / "scenarios" / "quickstart.yaml", 0.5)
    raw["sim"]["integrator"] = "RK4"
    scs = [parse_scenario(raw)]
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "full" and sim_c.plant.road_dof
    assert rp[0].ts.equals(rc[0].ts)


def test_divergence_is_reported_at_the_same_time(monkeypatch):
    # an end stop far too stiff for the 0.5 ms step (explicit force): the stroke blows up.  The structure of
    # _bench_like (its effects, sensors and controller), so that this runs the loop the tests above compiled
    sc = _bench_like(1, vehicle={"model": "quarter_car",
                                 "effects": [{"type": "quadratic_damping", "params": {"c_v": 300.0}},
                                             {"type": "bump_stop", "params": {"gap": 0.001, "stiffness": 1e10}}]},
                     road={"type": "sine", "params": {"amplitude": 0.03, "frequency": 2.0}, "speed": 20.0},
                     sim={"duration": 2.0})[0]
    errs = {}
    for compiled in (True, False):
        monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
        with pytest.raises(SimulationDiverged) as ei:
            Simulation([sc]).run()
        errs[compiled] = str(ei.value)
    assert errs[True] == errs[False]


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_divergence_keeps_the_log_up_to_the_stop(compiled, monkeypatch):
    """A run that stops on the divergence check carries its log up to the stop (``SimulationDiverged.log``), so a
    figure of the runaway needs no rerun: every log instant before the stop, and value for value the log of the
    same run cut short before it (what the rerun gave).  An exception made elsewhere has none."""
    raw = {"name": "unstable", "vehicle": {"model": "quarter_car",
                                           "effects": [{"type": "bump_stop", "params": {"gap": 0.001, "stiffness": 1e10}}]},
           "road": {"type": "sine", "params": {"amplitude": 0.03, "frequency": 2.0}, "speed": 20.0},
           "sensors": [{"type": "corner_body_vel"}],
           "controller": {"type": "skyhook"}, "sim": {"duration": 2.0}}
    sc = parse_scenario(raw)
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    with pytest.raises(SimulationDiverged) as ei:
        Simulation([sc]).run()
    e = ei.value
    log = e.log[0]
    t = log.t.to_numpy()
    assert len(t) > 10 and t[-1] < e.time <= t[-1] + sc.sim.log_dt + 1e-12, (t[-1], e.time)
    assert np.array_equal(t, np.arange(len(t)) * sc.sim.log_dt)  # every instant before the stop, none after
    short = parse_scenario({**raw, "sim": {"duration": round(e.time - 5 * sc.sim.log_dt, 6)}})
    ts = Simulation([short]).run()[0].ts
    assert len(ts) < len(log) and list(ts.columns) == list(log.columns)
    assert log.iloc[:len(ts)].reset_index(drop=True).equals(ts.reset_index(drop=True))
    assert SimulationDiverged(0.1, {}, "h").log is None


def test_progress_and_log_hooks_see_every_log_step(monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    sc = _bench_like(1)[0]
    sim = Simulation([sc])
    seen, prog = [], []
    sim.log_hooks.append(lambda logger, j, t: seen.append((j, t, float(logger.ch["body_z"][0, j]))))
    res = sim.run(progress=prog.append)
    assert sim.loop == "full"
    assert [j for j, _, _ in seen] == list(range(len(res[0].ts)))
    assert np.allclose([t for _, t, _ in seen], res[0].ts["t"].to_numpy())
    assert np.array_equal([z for _, _, z in seen], res[0].ts["body_z"].to_numpy())
    assert prog[-1] == 1.0


def test_controller_without_kernel_data_runs_hybrid(monkeypatch):
    """A controller class with a kernel that declines a setting (kernel_data raises NotImplementedError) and
    a numpy step for it is called from Python at control instants, with the same results."""
    from suspension_sim.controllers.skyhook import Skyhook
    from suspension_sim.registry import CONTROLLERS

    if "_test_declines_kernel" not in CONTROLLERS._items:
        @CONTROLLERS.register("_test_declines_kernel")
        class Declines(Skyhook):
            def kernel_data(self):
                raise NotImplementedError("not for this setting")

            def step(self, t, y):
                return -self.p.c_sky * y["corner_body_vel"]

            def signals(self):
                return {}

    scs = _bench_like(2, controller={"type": "_test_declines_kernel", "params": {"c_sky": 2000.0}})
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "hybrid" and "not for this setting" in sim_c.loop_reason
    for a, b in zip(rp, rc):
        assert a.ts.equals(b.ts)


def test_trapezoidal_compiled_is_bit_identical(monkeypatch):
    """The trapezoidal scheme's explicit damper halves and body-wheel coupling forces: same arithmetic on
    both loops (quarter-car ensemble with effects, and the full car with its pitch and roll)."""
    scs = _bench_like(3, sim={"duration": 0.6, "integrator": "trapezoidal"})
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "full"
    for a, b in zip(rp, rc):
        assert a.ts.equals(b.ts)
    raw = _raw(ROOT / "scenarios" / "full_car_bump.yaml", 0.5)
    raw["sim"]["integrator"] = "trapezoidal"
    scs = [parse_scenario(raw)]
    sim_c, rc = _run(scs, True, monkeypatch)
    _, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "full"
    _assert_same(rp[0], rc[0])


def test_metrics_only_logging_equals_the_full_log(monkeypatch):
    """A batch without time series logs only the channels the metrics read (the others' tables are dropped):
    those channels and every metric equal the run that logs everything, bit for bit."""
    scs = _bench_like(3)
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    full = Simulation(scs).run()
    sim = Simulation(scs, log_channels="metrics")
    part = sim.run()
    assert sim.loop == "full"
    for a, b in zip(full, part):
        kept = list(b.ts.columns)
        assert 3 <= len(kept) < len(a.ts.columns) and not any(c.startswith(("ctrl.", "sensor.", "act.")) for c in kept)
        assert a.ts[kept].equals(b.ts)
        assert a.metrics == b.metrics


def test_shared_parameter_rows_and_logged_tables():
    """The loop reads each car's kernel parameters through one row per distinct parameter set (bit for bit: -0.0
    and 0.0 are different rows, equal NaNs one); and the log tables keep the rows that log anything."""
    from suspension_sim.compiled.loop import _logged, _shared_rows

    a = np.zeros((6, 2, 3))
    a[1, 0, 0] = -0.0
    a[2] = a[4] = np.nan
    a[3, 1, 2] = 7.0
    rows, idx = _shared_rows(a)
    assert len(rows) == 4 and idx.dtype == np.int64 and rows.flags.c_contiguous
    assert rows[idx].tobytes() == a.tobytes()
    assert idx[0] == idx[5] and idx[2] == idx[4] and len({idx[0], idx[1], idx[2], idx[3]}) == 4
    one, idx1 = _shared_rows(np.ones((5, 4)))
    assert one.shape == (1, 4) and not idx1.any()
    lc = np.array([[9, 9], [3, 9], [9, 9], [4, 5]])
    kept, (src,) = _logged(lc, 9, np.array([10, 11, 12, 13]))
    assert kept.tolist() == [[3, 9], [4, 5]] and src.tolist() == [11, 13]
    kept, (src,) = _logged(np.array([9, 2, 9]), 9, np.arange(3))
    assert kept.tolist() == [2] and src.tolist() == [1]


def test_a_read_only_road_chunk_runs_the_loop_compiled_for_a_writable_one(monkeypatch):
    """numba compiles a function once per argument type, and a read-only array is another type than a writable
    one: the discrepancy workflow's one-car road (a broadcast view) compiled every loop it ran a second time
    (1-3 min each under load).  The loop receives writable road chunks, so one signature serves both; the
    read-only chunk gives the same run."""
    from suspension_sim.compiled import loop as cl

    used = []
    monkeypatch.setattr(cl, "load_module", lambda *a, load=cl.load_module: used.append(load(*a)) or used[-1])
    sc = parse_scenario({"name": "ro", "vehicle": {"model": "quarter_car"}, "sim": {"duration": 0.2},
                         "road": {"type": "sine", "params": {"frequency": 3.0, "amplitude": 0.01}}})
    ref = Simulation([sc]).run()[0]
    sim = Simulation([sc])
    chunk = sim.road_chunk

    def read_only(k0, k1):
        out = []
        for a in chunk(k0, k1):
            a = a.view()
            a.flags.writeable = False
            out.append(a)
        return tuple(out)

    sim.road_chunk = read_only
    assert not read_only(0, 10)[0].flags.writeable
    res = sim.run()[0]
    assert len(used) == 2 and used[0] is used[1]
    assert len(used[0].loop.signatures) == 1, used[0].loop.signatures
    _assert_same(ref, res, rel=0)


def test_named_channel_logging_equals_the_full_log(monkeypatch):
    """A set of channel names as ``log_channels`` (diagnose's engine) logs those channels only, each equal to
    the run that logs everything, bit for bit."""
    from suspension_sim.compiled.loop import plan, run as run_compiled
    from suspension_sim.log import Logger

    scs = _bench_like(2)
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    full = Simulation(scs).run()
    sim = Simulation(scs)
    sim.log_channels = {"body_z", "travel", "body_acc"}
    mode, _ = plan(sim)
    logger = Logger(sim, n_log=len(full[0].ts))
    run_compiled(sim, mode, None, logger)
    assert sorted(logger.ch) == ["body_acc", "body_z", "travel"]
    for name, a in logger.ch.items():
        assert np.array_equal(a, np.stack([r.ts[name].to_numpy() for r in full])), name


def test_mujoco_profiling_timers_are_off():
    """The compiled loop's MuJoCo runs without the profiling clock the Python bindings install (mjcb_time: ~40
    clock reads per step, 45 % of a one-car quarter-car step): the timers stay at zero."""
    import ctypes

    import mujoco

    from suspension_sim.compiled import mj

    assert mj.load() is None
    assert ctypes.c_void_p.in_dll(ctypes.CDLL(mj.library_path()), "mjcb_time").value is None
    m = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><joint type='slide'/><geom size='.1'/></body>"
                                       "</worldbody></mujoco>")
    d = mujoco.MjData(m)
    for _ in range(10):
        mujoco.mj_step(m, d)
    assert d.timer[int(mujoco.mjtTimer.mjTIMER_STEP)].duration == 0.0
    assert d.qpos[0] < 0  # it did step (falls under gravity)


def test_loop_with_its_switches_as_constants_equals_the_generic_loop(monkeypatch):
    """run_steps generates each loop with its switches (integrator, tires, road plates, effects, manoeuvre), the
    log's column table and the sensors' layout written in as constants (generate_source's ``spec``, issue 15);
    the loop generated without them, reading the same values from its arguments, gives the same bits: noisy,
    delayed and quantised sensors (the ring buffer), every channel and metrics only, trapezoidal and RK4."""
    from suspension_sim.compiled import loop as cl

    load, specs = cl.load_module, []

    def generic(*a):
        specs.append(a[5])
        return load(*a[:5])

    for integrator, channels in (("trapezoidal", "all"), ("trapezoidal", "metrics"), ("RK4", "all")):
        scs = _bench_like(2, sim={"duration": 0.3, "seed": 1, "integrator": integrator})
        sim = Simulation(scs, log_channels=channels)
        ref = sim.run()
        assert sim.loop == "full", sim.loop_reason
        monkeypatch.setattr(cl, "load_module", generic)
        res = Simulation(scs, log_channels=channels).run()
        monkeypatch.setattr(cl, "load_module", load)
        flags, cols, sens = specs[-1]
        assert dict(zip(cl.SPEC_FLAGS, flags))["rk4"] == (integrator == "RK4") and cols is not None and len(sens) == 3
        for a, b in zip(ref, res):
            assert (a.ts is None) == (b.ts is None) and (a.ts is None or a.ts.equals(b.ts))
            assert a.metrics == b.metrics
