"""Closed-loop speed, printed side by side from one run on this machine (issue 7).

1. A single closed-loop run — quarter car with two nonlinear effects (quadratic damping, bump stops), the
   thesis's continuous direct MRAC (controllers/thesis_mrac_continuous.py, Ch. 3, used here as an SDOF
   design on the quarter car's body), ideal actuator, 0.5 ms physics, 1 ms control, 10 s of a 1.2 Hz
   road sine that drives the travel into the stops — against a plain scipy ``solve_ivp`` implementation
   of the same closed loop written below (the same 4-state plant equations, the same force laws, the same
   controller object called at the same 1 ms instants with zero-order hold).  Both are checked against a
   tight-tolerance reference (DOP853, rtol 1e-10) by NRMSE = rms(error) / rms(reference) of body
   position, travel and actuator force (≤ 1 % required).  Speed ratio = scipy time / suspension_sim time.
2. Batch cost per car-step (an ensemble of cars in one MuJoCo model, same closed loop) against raw
   ``mujoco.mj_step`` with ``nstep`` (a C loop, no Python) on (a) models/quarter_car.xml alone and (b) the
   very same ensemble model.
3. Real-time factors (simulated seconds per CPU second of one core), single and batch, for the stepping
   loop and end to end (model build + loop + metrics).
4. Dask distributed, 1 and 2 local workers, the same sweep: the scaling ratio t(1) / t(2).

Times are CPU seconds of this process (``time.process_time``) where one process does the work, because
the machine is shared (other jobs inflate wall time); Dask scaling is wall time by nature.  The load
average is printed alongside.

Run:  python benchmarks/bench_speed.py [--quick]
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

QUICK = "--quick" in sys.argv
DURATION = 10.0
EFFECTS = [{"type": "quadratic_damping", "params": {"c_v": 300.0}},
           {"type": "bump_stop", "params": {"gap": 0.03, "stiffness": 40000.0}}]
CTRL = {"type": "thesis_mrac_continuous",
        "params": {"mass": 290.0, "stiffness": 16812.0, "damping": 1000.0, "ref_mass": 290.0,
                   "ref_stiffness": 16812.0, "ref_damping": 6000.0}}
ROAD_A, ROAD_F = 0.03, 1.2


# the benchmark's integrator first (single run and batch), then the alternatives shown in part 1
INTEGRATORS = ("trapezoidal", "implicitfast", "RK4")


def scenario_raw(duration=DURATION, amplitude=ROAD_A, frequency=ROAD_F, seed=0, integrator=INTEGRATORS[0]):
    return {
        "name": "bench",
        "vehicle": {"model": "quarter_car", "effects": EFFECTS},
        "road": {"type": "sine", "params": {"amplitude": amplitude, "frequency": frequency}, "speed": 20.0},
        "sensors": [{"type": s} for s in ("body_pos", "body_vel", "road", "road_vel")],
        "actuator": {"type": "ideal"},
        "controller": CTRL,
        "sim": {"duration": duration, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001, "seed": seed,
                "integrator": integrator},
        "outputs": {"timeseries": True, "plots": False},
    }


# ------------------------------------------------------------------------------------------------------
# the same closed loop in plain scipy
# ------------------------------------------------------------------------------------------------------
def scipy_closed_loop(controller, duration, control_dt, rtol, atol, method="RK45"):
    """Quarter car (positions from equilibrium), quadratic damping + bump stop on the travel, ideal
    actuator, road z_r = A sin(2π f t); the controller is called every control_dt, its force held."""
    from scipy.integrate import solve_ivp

    mb, mw, ks, cs, kt = 290.0, 59.0, 16812.0, 1000.0, 190000.0
    cv, gap, kstop = 300.0, 0.03, 40000.0
    w = 2 * np.pi * ROAD_F

    def road(t):
        return ROAD_A * np.sin(w * t), ROAD_A * w * np.cos(w * t)

    def rhs(t, x, F):
        zb, vb, zw, vw = x
        s, v = zb - zw, vb - vw
        f_susp = -ks * s - cs * v - cv * v * abs(v) + F
        if s < -gap:
            f_susp += kstop * (-gap - s)
        elif s > gap:
            f_susp -= kstop * (s - gap)
        zr, _ = road(t)
        return (vb, f_susp / mb, vw, (-f_susp - kt * (zw - zr)) / mw)

    n = int(round(duration / control_dt))
    x = np.zeros(4)
    out = np.empty((n, 3))  # body_z, travel, actuator force at the control instants
    controller.reset()
    for k in range(n):
        t = k * control_dt
        zr, vr = road(t)
        y = {"body_pos": np.array([[x[0]]]), "body_vel": np.array([[x[1]]]), "road": np.array([[zr]]),
             "road_vel": np.array([[vr]])}
        F = float(np.asarray(controller.step(t, y)).reshape(-1)[0])
        out[k] = x[0], x[0] - x[2], F
        sol = solve_ivp(rhs, (t, t + control_dt), x, method=method, rtol=rtol, atol=atol, args=(F,))
        x = sol.y[:, -1]
    return out


def timed_step(ctrl, acc):
    """Wrap ctrl.step to add its CPU time to acc[0]."""
    inner = ctrl.step

    def step(t, y):
        c = time.process_time()
        out = inner(t, y)
        acc[0] += time.process_time() - c
        return out

    ctrl.step = step
    return ctrl


def nrmse(a, ref):
    return float(np.sqrt(np.mean((a - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)))


def load_avg():
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover
        return float("nan")


# ------------------------------------------------------------------------------------------------------
def _best(fn, repeats):
    """(best CPU seconds of ``repeats`` calls of fn, its last return value)."""
    best, out = float("inf"), None
    for _ in range(repeats):
        c = time.process_time()
        out = fn()
        best = min(best, time.process_time() - c)
    return best, out


def part1_single(repeats=3):
    import mujoco  # noqa: F401

    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    runs = {}
    for integ in INTEGRATORS:
        sc = parse_scenario(scenario_raw(integrator=integ))
        Simulation([parse_scenario(scenario_raw(duration=0.05, integrator=integ))]).run()  # load its compiled loop
        t_build, _ = _best(lambda: Simulation([sc]), repeats)
        holder = {}

        def run_once():
            s = Simulation([sc])
            c = time.process_time()
            holder["res"] = s.run()[0]
            holder["sim"] = s
            return time.process_time() - c

        t_run = min(run_once() for _ in range(repeats))
        ts = holder["res"].ts
        runs[integ] = dict(t=t_run, t_build=t_build, loop=holder["sim"].loop, sim=holder["sim"],
                           y=np.column_stack([ts["body_z"].to_numpy(), ts["travel"].to_numpy(),
                                              ts["actuator_force"].to_numpy()]))
    sim = runs[INTEGRATORS[0]]["sim"]
    # the benchmark's scenario through the Python loop (the fallback path; its results are the compiled loop's)
    os.environ["SUSPENSION_SIM_COMPILED"] = "0"
    try:
        t_py, _ = _best(lambda: Simulation([parse_scenario(scenario_raw())]).run(), 1)
    finally:
        os.environ.pop("SUSPENSION_SIM_COMPILED")
    ctrl_cls, ctrl_p, cctx = type(sim.controller), sim.controller.p, sim.cctx

    def fresh():
        return ctrl_cls(ctrl_p, cctx)

    t_plain, plain = _best(lambda: scipy_closed_loop(fresh(), DURATION, 0.001, rtol=1e-6, atol=1e-9), repeats)
    t_ctrl_plain = [0.0]
    scipy_closed_loop(timed_step(fresh(), t_ctrl_plain), DURATION, 0.001, rtol=1e-6, atol=1e-9)
    ref = scipy_closed_loop(fresh(), DURATION, 0.001, rtol=1e-10, atol=1e-13, method="DOP853")
    n = min(len(plain), len(ref))
    for r in runs.values():
        r["err"] = [nrmse(r["y"][:n, j], ref[:n, j]) for j in range(3)]
        r["rtf"], r["rtf_e2e"] = DURATION / r["t"], DURATION / (r["t"] + r["t_build"])
    err_plain = [nrmse(plain[:n, j], ref[:n, j]) for j in range(3)]
    stops = float(np.mean(np.abs(ref[:, 1]) > 0.03))
    return dict(runs=runs, t_plain=t_plain, err_plain=err_plain, t_py=t_py, t_ctrl_plain=t_ctrl_plain[0],
                stops=stops)


def part2_batch(n_cars=256, duration=2.0, repeats=3):
    import mujoco

    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation
    from suspension_sim.vehicles.base import models_dir

    rng = np.random.default_rng(0)
    scs = [parse_scenario(scenario_raw(duration=duration, amplitude=float(a), frequency=float(f)))
           for a, f in zip(rng.uniform(0.01, 0.03, n_cars), rng.uniform(0.8, 2.0, n_cars))]
    Simulation(scs[:2]).run()  # the compiled loop is loaded
    Simulation(scs[:2], log_channels="metrics").run()
    # what `suspension-sim batch` does without keep_timeseries: log only the channels the metrics read

    def run_metrics_only():
        s = Simulation(scs, log_channels="metrics")
        c = time.process_time()
        ms = [r.metrics for r in s.run()]
        assert all(np.isfinite(m["body_acc_rms"]) for m in ms)
        return time.process_time() - c

    t_metrics_only = min(run_metrics_only() for _ in range(repeats))
    best = None
    for _ in range(repeats):
        c0 = time.process_time()
        sim = Simulation(scs)
        c1 = time.process_time()
        res = sim.run()
        c2 = time.process_time()
        metrics = [r.metrics for r in res]  # metrics of every car (computed for the whole ensemble at once)
        c3 = time.process_time()
        if best is None or (c3 - c0) < best[0]:
            best = (c3 - c0, c1 - c0, c2 - c1, c3 - c2, sim)
    total, t_build, t_run, t_metrics, sim = best
    assert all(np.isfinite(m["body_acc_rms"]) for m in metrics)
    n_steps = sim.n_steps
    per_car_step = t_run / (n_cars * n_steps)
    # raw MuJoCo, no Python in the loop: the file alone, and the very ensemble model the batch steps
    m1 = mujoco.MjModel.from_xml_path(str(models_dir() / "quarter_car.xml"))
    d1 = mujoco.MjData(m1)
    raw_single, _ = _best(lambda: mujoco.mj_step(m1, d1, nstep=20000), 3)
    raw_single /= 20000
    me, de = sim.plant.model, mujoco.MjData(sim.plant.model)
    raw_ens, _ = _best(lambda: mujoco.mj_step(me, de, nstep=400), 3)
    raw_ens /= 400 * n_cars
    return dict(n_cars=n_cars, duration=duration, t_build=t_build, t_run=t_run, t_metrics=t_metrics,
                t_run_mo=t_metrics_only, rtf_batch_mo=n_cars * duration / t_metrics_only,
                loop=sim.loop, per_car_step=per_car_step, raw_single=raw_single, raw_ens=raw_ens,
                nv=me.nv // n_cars, rtf_batch=n_cars * duration / t_run, rtf_batch_e2e=n_cars * duration / total,
                rtf_raw_ens=0.0005 / raw_ens, rtf_raw_single=0.0005 / raw_single)


SWEEP = """
name: bench_dask
base: {base}
grid:
  road.params.amplitude: [0.01, 0.015, 0.02, 0.025]
  road.params.frequency: [0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2]
seeds: {{count: {seeds}, start: 0}}
ensemble_size: {ens}
"""


def part4_dask(duration=10.0, ens=16, seeds=8):
    import yaml

    from suspension_sim.batch import DaskEngine, run_batch

    tmp = Path(tempfile.mkdtemp(prefix="bench_dask_"))
    (tmp / "base.yaml").write_text(yaml.safe_dump(scenario_raw(duration=duration)))
    (tmp / "sweep.yaml").write_text(SWEEP.format(base="base.yaml", ens=ens, seeds=seeds))
    runs = 32 * seeds
    out = {}
    for nw in (1, 2):
        eng = DaskEngine(None, nw)
        try:
            run_batch(tmp / "sweep.yaml", out=tmp / f"warm{nw}", engine=eng, resume=False)  # imports, kernels
            w0 = eng.client.run(time.process_time)
            c = time.process_time()
            t = time.perf_counter()
            rep = run_batch(tmp / "sweep.yaml", out=tmp / f"o{nw}", engine=eng, resume=False)
            out[nw] = time.perf_counter() - t
            w1 = eng.client.run(time.process_time)
            out[f"cpu_workers{nw}"] = sum(w1[k] - w0[k] for k in w0)
            out[f"cpu_driver{nw}"] = time.process_time() - c
            assert rep.counts == {"ok": runs}, rep.counts
        finally:
            eng.close()
    out["ratio"] = out[1] / out[2]
    out["runs"], out["duration"], out["ens"] = runs, duration, ens
    return out


def main():
    print(f"machine: {os.cpu_count()} cores, load average {load_avg():.1f} at start; python {sys.version.split()[0]}")
    p1 = part1_single()
    print("\n1. single closed-loop run: quarter car, quadratic damping + bump stops, thesis continuous MRAC,")
    print(f"   dt 0.5 ms, control 1 ms, {DURATION:g} s (travel beyond the stop gap {100 * p1['stops']:.1f} % of the time)")
    print(f"   {'':40s}{'CPU s':>8s}{'RT factor':>11s}{'NRMSE body_z':>14s}{'travel':>9s}{'force':>9s}")
    for integ, r in p1["runs"].items():
        e = r["err"]
        print(f"   {'suspension_sim ' + integ + ' (' + r['loop'] + ' compiled)':40s}{r['t']:8.3f}{r['rtf']:10.0f}x"
              f"{100 * e[0]:13.3f}%{100 * e[1]:8.3f}%{100 * e[2]:8.3f}%")
    e = p1["err_plain"]
    print(f"   {'scipy solve_ivp RK45 1e-6':40s}{p1['t_plain']:8.3f}{DURATION / p1['t_plain']:10.1f}x"
          f"{100 * e[0]:13.3f}%{100 * e[1]:8.3f}%{100 * e[2]:8.3f}%")
    r0 = p1["runs"][INTEGRATORS[0]]
    others = " / ".join(f"{k} {p1['t_plain'] / v['t']:.1f}x" for k, v in p1["runs"].items())
    print(f"   speed ratio scipy / suspension_sim ({INTEGRATORS[0]}): {p1['t_plain'] / r0['t']:.1f}x  (target >= 20x; "
          f"{others})")
    print(f"   the scipy loop's Python controller alone: {p1['t_ctrl_plain']:.3f} s; without it scipy would take "
          f"{p1['t_plain'] - p1['t_ctrl_plain']:.3f} s ({(p1['t_plain'] - p1['t_ctrl_plain']) / r0['t']:.1f}x)")
    print(f"   the same run through the Python loop (fallback path, same results): {p1['t_py']:.3f} s")
    print(f"   model build (not in the ratio): {r0['t_build']:.3f} s")

    p2 = part2_batch(n_cars=64 if QUICK else 256)
    print(f"\n2. batch: {p2['n_cars']} cars in one MuJoCo model ({p2['loop']} compiled loop), same closed loop, "
          f"{p2['duration']:g} s each")
    print(f"   loop cost per car-step                    {1e6 * p2['per_car_step']:8.3f} us")
    print(f"   raw mj_step, models/quarter_car.xml alone {1e6 * p2['raw_single']:8.3f} us   ratio "
          f"{p2['per_car_step'] / p2['raw_single']:.2f}x")
    print(f"   raw mj_step, the same ensemble model      {1e6 * p2['raw_ens']:8.3f} us   ratio "
          f"{p2['per_car_step'] / p2['raw_ens']:.2f}x  (target <= 2x)")
    print(f"   ({p2['nv']} dofs per car: the road enters as the tire springs' rest length, not as a plate dof)")
    print(f"   build {p2['t_build']:.2f} s, run {p2['t_run']:.2f} s, metrics of all cars {p2['t_metrics']:.2f} s")
    per_mo = p2['t_run_mo'] / (p2['n_cars'] * p2['duration'] / 0.0005)
    print(f"   logging only what the metrics read (the batch engine without keep_timeseries): "
          f"{1e6 * per_mo:.3f} us per car-step, ratio {per_mo / p2['raw_ens']:.2f}x")

    print("\n3. real-time factors (simulated s per CPU s, one core)")
    print(f"   single run: run {r0['rtf']:8.1f}x   with model build {r0['rtf_e2e']:8.1f}x   (target >= 100x)")
    print(f"   batch:      run {p2['rtf_batch']:8.1f}x   with build + metrics {p2['rtf_batch_e2e']:8.1f}x   (target >= 1000x)")
    print(f"   batch, metrics-only logging (the batch engine's default): run {p2['rtf_batch_mo']:8.1f}x")
    print(f"   raw MuJoCo: quarter_car.xml alone {p2['rtf_raw_single']:.0f}x, ensemble {p2['rtf_raw_ens']:.0f}x per car")

    if "--no-dask" not in sys.argv:
        p4 = part4_dask(duration=4.0 if QUICK else 10.0)
        print(f"\n4. Dask local cluster, {p4['runs']} runs x {p4['duration']:g} s, ensembles of {p4['ens']} (wall time)")
        print(f"   1 worker {p4[1]:.2f} s, 2 workers {p4[2]:.2f} s: scaling {p4['ratio']:.2f}x  (target >= 1.8x)")
        for nw in (1, 2):
            print(f"   {nw} worker(s): worker CPU {p4[f'cpu_workers{nw}']:.2f} s, driver CPU {p4[f'cpu_driver{nw}']:.2f} s, "
                  f"wall {p4[nw]:.2f} s (CPU/wall {p4[f'cpu_workers{nw}'] / p4[nw]:.2f} cores used)")
    print(f"\nload average at end {load_avg():.1f}")


if __name__ == "__main__":
    main()
