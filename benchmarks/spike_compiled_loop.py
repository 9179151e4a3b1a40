"""Measurement spike (issue 7, Speed): how fast can the closed loop get when the whole per-step loop is compiled?

Not a production change: nothing in the package is touched.  For the quarter car (``models/quarter_car.xml``
built through ``suspension_sim``'s :class:`~suspension_sim.plant.Plant`, one car and ensembles of 64 / 256
cars) it measures side by side, in CPU seconds of this process (``time.process_time``, best of several
repeats, because the machine is shared):

(a) raw MuJoCo: ``mujoco.mj_step`` called from a Python loop, and ``mujoco.mj_step(m, d, nstep=N)`` (the C
    loop); also ``mj_step1`` + ``mj_step2`` called from a numba loop with nothing else (the floor of (b));
(b) a numba ``@njit`` loop that calls ``mj_step1`` / ``mj_step2`` of the MuJoCo shared library (next to the
    ``mujoco`` package) through ctypes function pointers, with the ``MjModel``/``MjData`` addresses
    (``_address``), sets the road plates from a precomputed array (the very array the Simulation computes,
    ``Simulation._road_chunk``), computes quadratic damping + bump-stop forces from ``ten_length`` /
    ``ten_velocity`` (the numpy arrays of ``MjData`` alias its memory, so the kernel reads and writes MuJoCo's
    own buffers), runs a compiled controller every 1 ms (skyhook, or a small gradient-adaptive skyhook
    standing in for an adaptive controller) and logs every 1 ms into a preallocated array;
(c) the current ``suspension_sim`` loop on the same case: ``Simulation([...]).run()``, with the same
    controllers as Python components (the built-in ``skyhook``; the adaptive law registered below).

It checks (b) against (c) (same forces in the same order of operations: the trajectories must agree to
~1e-9, in fact bit for bit), prints µs per car-step, real-time factor per core and the ratio to raw
``mj_step``, measures numba's compile time (first call) and whether ``cache=True`` works (in fresh
subprocesses, with a throw-away ``NUMBA_CACHE_DIR``), for the ctypes kernel and for a variant that binds
the MuJoCo symbols by name (``llvmlite`` ``load_library_permanently`` + ``numba.types.ExternalFunction``).

Run:  python benchmarks/spike_compiled_loop.py [--quick]
"""
from __future__ import annotations

import ctypes
import glob
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import mujoco  # noqa: E402
import numba  # noqa: E402
from numba import njit, types  # noqa: E402

CACHE = os.environ.get("SPIKE_CACHE", "0") == "1"
QUICK = "--quick" in sys.argv
DT, CONTROL_DT, LOG_DT = 0.0005, 0.001, 0.001

# ------------------------------------------------------------------------------------------------------
# MuJoCo's C entry points, two ways
# ------------------------------------------------------------------------------------------------------
LIBPATH = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))[0]
_lib = ctypes.CDLL(LIBPATH)
c_step1, c_step2 = _lib.mj_step1, _lib.mj_step2
for _f in (c_step1, c_step2):
    # pointers passed as 64-bit integers (same ABI as a pointer on x86-64 / aarch64)
    _f.argtypes = [ctypes.c_uint64, ctypes.c_uint64]
    _f.restype = None

# by symbol name: LLVM resolves it in the loaded library at link time, so the compiled code holds no
# process-specific address (what numba's cache=True needs)
import llvmlite.binding as _llvm  # noqa: E402

_llvm.load_library_permanently(LIBPATH)
x_step1 = types.ExternalFunction("mj_step1", types.void(types.uint64, types.uint64))
x_step2 = types.ExternalFunction("mj_step2", types.void(types.uint64, types.uint64))


# ------------------------------------------------------------------------------------------------------
# the compiled closed loop
# ------------------------------------------------------------------------------------------------------
STEP1 = STEP2 = None  # placeholders: each compiled variant gets its own globals (see _variant)


def _kernel(m_addr, d_addr, qpos, qvel, ctrl, ten_len, ten_vel,
            road_q, road_v, road_servo, susp_t, wheel_q, wheel_v, body_q, body_v, act, eff_s, eff_t,
            road_z, road_zd,
            cv, gap_c, gap_e, kstop, cstop,
            mode, c0, gamma, sigma, cmax, theta, cmd,
            sub, log_every, k_begin, k_end, n_steps, dt, control_dt, log):
    """Closed loop over physics steps k_begin..k_end-1.  Index grids (n, nc) into MjData arrays; road_z/road_zd
    (n, n_steps, nc); per-car/corner parameters (n, nc); log (n, n_log, 10); cmd (n, nc) the held command.

    mode 0 = compiled skyhook F = -c0·v_b; 1 = compiled gradient-adaptive skyhook F = -(c0 + θ)·v_b,
    θ' = γ·v_b² − σ·θ (clipped to [0, cmax]); 2 = the command comes from outside (a Python controller called
    between kernel calls): then step k_begin's mj_step1 was done by the previous call, and the call ends
    with the road and mj_step1 of step k_end, so that the caller reads the state at the control instant."""
    n, nc = road_q.shape
    for k in range(k_begin, k_end):
        if mode != 2:
            for i in range(n):
                for c in range(nc):
                    z = road_z[i, k, c]
                    qpos[road_q[i, c]] = z
                    qvel[road_v[i, c]] = road_zd[i, k, c]
                    ctrl[road_servo[i, c]] = z
            STEP1(m_addr, d_addr)
        if k % sub == 0 and mode != 2:  # controller (zero-order hold until the next control instant)
            for i in range(n):
                for c in range(nc):
                    vb = ten_vel[susp_t[i, c]] + qvel[wheel_v[i, c]]  # corner_body_vel, as the sensors
                    if mode == 0:
                        cmd[i, c] = -c0[i, c] * vb
                    else:
                        th = theta[i, c]
                        cmd[i, c] = -(c0[i, c] + th) * vb
                        th = th + (gamma[i, c] * vb * vb - sigma[i, c] * th) * control_dt
                        theta[i, c] = min(max(th, 0.0), cmax[i, c])
        log_now = k % log_every == 0
        j = k // log_every
        for i in range(n):
            for c in range(nc):
                s = ten_len[susp_t[i, c]]
                v = ten_vel[susp_t[i, c]]
                f = 0.0
                f += -cv[i, c] * v * abs(v)  # quadratic damping, as effects/quadratic_damping.py
                pc = -gap_c[i, c] - s  # bump stops, as effects/bump_stop.py
                pe = s - gap_e[i, c]
                fc = max(0.0, kstop[i, c] * pc - cstop[i, c] * v) if pc > 0 else 0.0
                fe = min(0.0, -kstop[i, c] * pe - cstop[i, c] * v) if pe > 0 else 0.0
                f += fc + fe
                ctrl[eff_s[i, c]] = f
                ctrl[eff_t[i, c]] = 0.0
                ctrl[act[i, c]] = cmd[i, c]  # ideal actuator
                if log_now:
                    log[i, j, 0] = k * dt
                    log[i, j, 1] = qpos[body_q[i, 0]]
                    log[i, j, 2] = qvel[body_v[i, 0]]
                    log[i, j, 3] = s
                    log[i, j, 4] = v
                    log[i, j, 5] = qpos[wheel_q[i, c]]
                    log[i, j, 6] = cmd[i, c]
                    log[i, j, 7] = cmd[i, c]
                    log[i, j, 8] = f
                    log[i, j, 9] = theta[i, c]
        STEP2(m_addr, d_addr)
        if mode == 2 and k + 1 < n_steps:  # the next step's road and mj_step1 (its state is read outside)
            for i in range(n):
                for c in range(nc):
                    z = road_z[i, k + 1, c]
                    qpos[road_q[i, c]] = z
                    qvel[road_v[i, c]] = road_zd[i, k + 1, c]
                    ctrl[road_servo[i, c]] = z
            STEP1(m_addr, d_addr)
    if mode == 2 and k_begin == k_end == 0:  # start: road and mj_step1 of step 0
        for i in range(n):
            for c in range(nc):
                z = road_z[i, 0, c]
                qpos[road_q[i, c]] = z
                qvel[road_v[i, c]] = road_zd[i, 0, c]
                ctrl[road_servo[i, c]] = z
        STEP1(m_addr, d_addr)
    return 0


def _bare(m_addr, d_addr, n_steps):
    for k in range(n_steps):
        STEP1(m_addr, d_addr)
        STEP2(m_addr, d_addr)
    return 0


def _variant(fn, name, step1, step2):
    """A copy of ``fn`` whose globals STEP1/STEP2 are the given MuJoCo entry points (numba reads a function's
    globals at compile time).  Its own __qualname__ gives it its own numba cache file."""
    import types as _pytypes

    g = dict(globals(), STEP1=step1, STEP2=step2)
    f = _pytypes.FunctionType(fn.__code__, g, name, fn.__defaults__)
    f.__qualname__ = name
    f.__doc__ = fn.__doc__
    return njit(cache=CACHE)(f)


kernel_ctypes = _variant(_kernel, "kernel_ctypes", c_step1, c_step2)
kernel_extern = _variant(_kernel, "kernel_extern", x_step1, x_step2)
bare_ctypes = _variant(_bare, "bare_ctypes", c_step1, c_step2)

LOG_NAMES = ["t", "body_z", "body_vel", "travel", "travel_rate", "wheel_z", "command", "actuator_force",
             "effect_force", "ctrl.theta"]


# ------------------------------------------------------------------------------------------------------
# the same case through suspension_sim (c)
# ------------------------------------------------------------------------------------------------------
def _register_adaptive():
    """The gradient-adaptive skyhook as an ordinary Python controller component (same law as the kernel)."""
    from pydantic import Field

    from controllers.base import Controller
    from suspension_sim.components import Params
    from suspension_sim.registry import CONTROLLERS

    if "spike_adaptive_skyhook" in CONTROLLERS._items:
        return

    class AdaptiveSkyhookParams(Params):
        c0: float = Field(1000.0, ge=0)
        gamma: float = Field(2e6, ge=0)
        sigma: float = Field(0.5, ge=0)
        c_max: float = Field(8000.0, ge=0)

    @CONTROLLERS.register("spike_adaptive_skyhook")
    class AdaptiveSkyhook(Controller):
        """F = -(c0 + θ)·v_b, θ' = γ·v_b² − σ·θ, θ in [0, c_max] (gradient of v_b²/2 w.r.t. the gain)."""

        Params = AdaptiveSkyhookParams
        requires = ("corner_body_vel",)

        def reset(self):
            self.theta = self.zeros()

        def step(self, t, y):
            vb = y["corner_body_vel"]
            th = self.theta
            f = -(self.p.c0 + th) * vb
            th = th + (self.p.gamma * vb * vb - self.p.sigma * th) * self.ctx.control_dt
            self.theta = np.minimum(np.maximum(th, 0.0), self.p.c_max)
            return f

        def signals(self):
            return {"theta": self.theta}


CTRL = {"skyhook": {"type": "skyhook", "params": {"c_sky": 2500.0}},
        "adaptive": {"type": "spike_adaptive_skyhook",
                     "params": {"c0": 1000.0, "gamma": 2e6, "sigma": 0.5, "c_max": 8000.0}}}
EFF = {"c_v": 300.0, "gap": 0.02, "stiffness": 40000.0}  # 2 cm: the stops engage 15-45 % of the time


def scenario(duration, amplitude=0.03, frequency=1.2, ctrl="adaptive"):
    from suspension_sim.config import parse_scenario

    return parse_scenario({
        "name": "spike",
        "vehicle": {"model": "quarter_car",
                    "effects": [{"type": "quadratic_damping", "params": {"c_v": EFF["c_v"]}},
                                {"type": "bump_stop", "params": {"gap": EFF["gap"], "stiffness": EFF["stiffness"]}}]},
        "road": {"type": "sine", "params": {"amplitude": amplitude, "frequency": frequency}, "speed": 20.0},
        "sensors": [{"type": "corner_body_vel"}],
        "actuator": {"type": "ideal"},
        "controller": CTRL[ctrl],
        "sim": {"duration": duration, "dt": DT, "control_dt": CONTROL_DT, "log_dt": LOG_DT, "seed": 0},
        "outputs": {"timeseries": True, "plots": False},
    })


def scenarios(n_cars, duration, ctrl):
    if n_cars == 1:
        return [scenario(duration, ctrl=ctrl)]
    rng = np.random.default_rng(0)
    return [scenario(duration, float(a), float(f), ctrl)
            for a, f in zip(rng.uniform(0.01, 0.03, n_cars), rng.uniform(0.8, 2.0, n_cars))]


# ------------------------------------------------------------------------------------------------------
class Compiled:
    """Everything the kernel needs, taken from a built Simulation (its Plant, parameters and road array)."""

    def __init__(self, sim, ctrl):
        P = sim.plant
        self.sim, self.P = sim, P
        self.m, self.d = P.model, mujoco.MjData(P.model)  # own MjData (the Simulation keeps P.data)
        n, nc = P.n, P.nc
        z, zd = sim._road_chunk(0, sim.n_steps)  # the Simulation's own road samples
        self.road_z, self.road_zd = np.ascontiguousarray(z), np.ascontiguousarray(zd)
        full = lambda v: np.full((n, nc), float(v))  # noqa: E731
        qd, bs = sim.effects[0][0], sim.effects[1][0]
        self.eff = (np.broadcast_to(qd.c_v, (n, nc)).astype(float), np.broadcast_to(bs.g_c, (n, nc)).astype(float),
                    np.broadcast_to(bs.g_e, (n, nc)).astype(float), np.broadcast_to(bs.k, (n, nc)).astype(float),
                    np.broadcast_to(bs.c, (n, nc)).astype(float))
        p = CTRL[ctrl]["params"]
        if ctrl == "skyhook":
            self.ctrl = (0, full(p["c_sky"]), full(0), full(0), full(0))
        else:
            self.ctrl = (1, full(p["c0"]), full(p["gamma"]), full(p["sigma"]), full(p["c_max"]))
        self.idx = tuple(np.ascontiguousarray(a, dtype=np.int64) for a in
                         (P.road_q, P.road_v, P.road_servo, P.susp_t, P.wheel_q, P.wheel_v, P.body_q, P.body_v,
                          P.act, P.eff_s, P.eff_t))
        self.sub, self.log_every, self.n_steps = sim.sub, sim.log_every, sim.n_steps
        self.log = np.zeros((n, self.n_steps // self.log_every, len(LOG_NAMES)))

    def run(self, kernel=kernel_ctypes):
        """(b): everything compiled, one kernel call for the whole run."""
        m, d = self.m, self.d
        mujoco.mj_resetData(m, d)
        theta = np.zeros_like(self.ctrl[1])
        cmd = np.zeros_like(theta)
        kernel(m._address, d._address, d.qpos, d.qvel, d.ctrl, d.ten_length, d.ten_velocity, *self.idx,
               self.road_z, self.road_zd, *self.eff, self.ctrl[0], *self.ctrl[1:], theta, cmd,
               self.sub, self.log_every, 0, self.n_steps, self.n_steps, DT, CONTROL_DT, self.log)
        return self.log

    def run_hybrid(self, controller, kernel=kernel_extern):
        """(b'): plant, effects, actuator and logging compiled; the controller stays a Python component,
        called every control step with {sensor: array} (the sensor reading done with numpy, as today)."""
        m, d = self.m, self.d
        mujoco.mj_resetData(m, d)
        controller.reset()
        theta = np.zeros_like(self.ctrl[1])
        cmd = np.zeros_like(theta)
        P = self.P
        susp, wv = P.susp_t, P.wheel_v
        args = (m._address, d._address, d.qpos, d.qvel, d.ctrl, d.ten_length, d.ten_velocity, *self.idx,
                self.road_z, self.road_zd, *self.eff, 2, *self.ctrl[1:], theta, cmd, self.sub, self.log_every)
        tail = (self.n_steps, DT, CONTROL_DT, self.log)
        kernel(*args, 0, 0, *tail)
        for k in range(0, self.n_steps, self.sub):
            y = {"corner_body_vel": d.ten_velocity[susp] + d.qvel[wv]}
            cmd[...] = controller.step(k * DT, y)
            kernel(*args, k, min(k + self.sub, self.n_steps), *tail)
        return self.log


def best(fn, repeats):
    out = []
    for _ in range(repeats):
        c = time.process_time()
        fn()
        out.append(time.process_time() - c)
    return min(out)


def measure(n_cars, duration, ctrl, repeats):
    import suspension_sim.results as R
    from suspension_sim.simulation import Simulation

    scs = scenarios(n_cars, duration, ctrl)
    c = time.process_time()
    sim = Simulation(scs)
    t_build = time.process_time() - c
    n_steps = sim.n_steps
    car_steps = n_cars * n_steps
    m = sim.plant.model
    # (a) raw MuJoCo -------------------------------------------------------------------------------
    d = mujoco.MjData(m)
    k_py = min(n_steps, max(2000, 400000 // n_cars))

    def py_loop():
        step = mujoco.mj_step
        for _ in range(k_py):
            step(m, d)

    t_py = best(py_loop, repeats) / (n_cars * k_py)
    t_nstep = best(lambda: mujoco.mj_step(m, d, nstep=n_steps), repeats) / car_steps
    t_bare = best(lambda: bare_ctypes(m._address, d._address, n_steps), repeats) / car_steps
    # (b) compiled closed loop ---------------------------------------------------------------------
    comp = Compiled(sim, ctrl)
    t_road = best(lambda: sim._road_chunk(0, n_steps), repeats) / car_steps  # not in (b): precomputed
    t_b = best(comp.run, repeats) / car_steps
    t_bx = best(lambda: comp.run(kernel_extern), repeats) / car_steps
    log_b = comp.run().copy()
    pyctrl = type(sim.controller)(sim.controller.p, sim.controller.ctx)
    t_h = best(lambda: comp.run_hybrid(pyctrl), repeats) / car_steps
    log_h = comp.run_hybrid(pyctrl).copy()
    c0 = time.process_time()
    for _ in range(100):
        pyctrl.step(0.0, {"corner_body_vel": np.zeros((n_cars, 1))})
    t_ctrl_call = (time.process_time() - c0) / 100
    # (c) the current loop -------------------------------------------------------------------------
    t_res = [0.0]
    orig = R.Result.from_logger

    def timed_from(*a, **k):
        c0 = time.process_time()
        out = orig(*a, **k)
        t_res[0] += time.process_time() - c0
        return out

    R.Result.from_logger = timed_from
    try:
        runs = []
        for _ in range(max(1, repeats - 1)):
            t_res[0] = 0.0
            c0 = time.process_time()
            res = sim.run()
            runs.append((time.process_time() - c0, t_res[0]))
    finally:
        R.Result.from_logger = orig
    t_c_total, t_c_res = min(runs)
    t_c_loop = (t_c_total - t_c_res) / car_steps
    # agreement (b) vs (c) -------------------------------------------------------------------------
    dev = {}
    for ch in ("body_z", "body_vel", "travel", "wheel_z", "actuator_force", "effect_force"):
        a = log_b[:, :, LOG_NAMES.index(ch)]
        b = np.stack([r.ts[ch].to_numpy() for r in res])
        dev[ch] = float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))
    if ctrl == "adaptive":
        a = log_b[:, :, LOG_NAMES.index("ctrl.theta")]
        b = np.stack([r.ts["ctrl.theta"].to_numpy() for r in res])
        # the Python logger logs signals() after the controller ran (θ updated), as the kernel does
        dev["ctrl.theta"] = float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))
    dev_h = 0.0
    for ch in ("body_z", "body_vel", "travel", "wheel_z", "actuator_force", "effect_force"):
        a, b = log_h[:, :, LOG_NAMES.index(ch)], log_b[:, :, LOG_NAMES.index(ch)]
        dev_h = max(dev_h, float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)))
    stops = float(np.mean(np.abs(log_b[:, :, LOG_NAMES.index("travel")]) > EFF["gap"]))
    return dict(n=n_cars, duration=duration, ctrl=ctrl, t_build=t_build, py=t_py, nstep=t_nstep, bare=t_bare,
                b=t_b, bx=t_bx, h=t_h, dev_h=dev_h, road=t_road, ctrl_call=t_ctrl_call, c_loop=t_c_loop, c_total=t_c_total / car_steps, c_res=t_c_res / car_steps,
                dev=dev, stops=stops, bitwise=all(v == 0.0 for v in dev.values()))


# ------------------------------------------------------------------------------------------------------
def compile_probe():
    """In a fresh process: time the first call (compile, or load from cache) of each kernel on a tiny case."""
    from suspension_sim.simulation import Simulation

    sim = Simulation([scenario(0.01)])
    comp = Compiled(sim, "adaptive")
    njit(lambda x: x + 1)(1)  # numba's own start-up, not counted
    out = {}
    for name, kern in (("ctypes", kernel_ctypes), ("extern", kernel_extern)):
        c = time.perf_counter()
        comp.run(kern)
        out[name] = time.perf_counter() - c
        out[name + "_cached"] = bool(kern.stats.cache_hits) if CACHE else False
    print("PROBE", out["ctypes"], out["extern"], out["ctypes_cached"], out["extern_cached"])


def cache_check():
    env = dict(os.environ, SPIKE_CACHE="1", NUMBA_CACHE_DIR=tempfile.mkdtemp(prefix="spike_numba_"))
    rows = []
    for label, e in (("no cache", dict(os.environ, SPIKE_CACHE="0")), ("cache, 1st process", env),
                     ("cache, 2nd process", env)):
        r = subprocess.run([sys.executable, __file__, "--probe"], env=e, capture_output=True, text=True, cwd=ROOT)
        line = [x for x in r.stdout.splitlines() if x.startswith("PROBE")]
        warn = [x.strip() for x in r.stderr.splitlines() if "cache" in x.lower() and "Warning" in x]
        if not line:
            rows.append((label, None, r.stderr[-400:]))
            continue
        _, tc, te, hc, he = line[0].split()
        rows.append((label, (float(tc), float(te), hc == "True", he == "True"), warn[:1]))
    return rows


def raw_model_variants(n=256, k=1000):
    """Raw ``mj_step(nstep)`` of a 256-car ensemble of models/quarter_car.xml as it is, and of two cheaper
    variants that a production design could use: the unused contact/constraint stages disabled (no effect
    on this model, which has neither), and the road plate's slide joint removed (the road then enters as
    a force k_t·z_r + c_t·ż_r on the tire tendon, written to ctrl like the effects; not bit-identical)."""
    import re

    xml = re.sub(r"<!--.*?-->", "", (ROOT / "models" / "quarter_car.xml").read_text(), flags=re.S)
    no_road = re.sub(r'<body name="road".*?</body>', "", xml, flags=re.S)
    no_road = no_road.replace('<joint joint="road_z" coef="-1"/>', "")
    no_road = no_road.replace('<position name="road" joint="road_z" kp="1e9" kv="1e6"/>', "")

    def ensemble(x):
        spec = mujoco.MjSpec()
        spec.option.timestep = DT
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        for i in range(n):
            spec.attach(mujoco.MjSpec.from_string(x), prefix=f"car{i}/",
                        frame=spec.worldbody.add_frame(pos=[0, 2.5 * i, 0]))
        return spec.compile()

    off = int(mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    out = []
    for label, x, flags in (("as today (road plate = slide joint + servo)", xml, 0),
                            ("as today, contact + constraint stages disabled", xml, off),
                            ("road plate removed (road as a tire force)", no_road, 0),
                            ("road plate removed, contact + constraint disabled", no_road, off)):
        m = ensemble(x)
        m.opt.disableflags |= flags
        d = mujoco.MjData(m)
        out.append((label, m.nv // n, best(lambda: mujoco.mj_step(m, d, nstep=k), 3) / (k * n)))
    return out


def mrac_call_cost(n_cars, duration=1.0):
    """CPU µs per call of the thesis MRAC (the controller of bench_speed.py) as a Python component."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_speed as B
    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    sim = Simulation([parse_scenario(B.scenario_raw(duration=duration)) for _ in range(n_cars)])
    acc = [0.0]
    B.timed_step(sim.controller, acc)
    sim.run()
    return acc[0] / round(duration / CONTROL_DT)


def main():
    _register_adaptive()
    import mujoco as _mj

    print(f"spike_compiled_loop  MuJoCo {_mj.__version__}  numba {numba.__version__}  dt {DT * 1e3} ms, control "
          f"{CONTROL_DT * 1e3} ms, log {LOG_DT * 1e3} ms  load avg {os.getloadavg()[0]:.1f}  (CPU time, best of N)")
    from suspension_sim.simulation import Simulation

    warm = Compiled(Simulation([scenario(0.01)]), "adaptive")  # compile once (first calls), timed
    first = {}
    for name, fn in (("ctypes kernel", lambda: warm.run(kernel_ctypes)), ("by-symbol kernel", lambda: warm.run(kernel_extern)),
                     ("bare mj_step1+2 loop", lambda: bare_ctypes(warm.m._address, warm.d._address, 1)),
                     ("by-symbol kernel, mode 2 (Python controller)", lambda: warm.run_hybrid(warm.sim.controller))):
        c = time.process_time()
        fn()
        first[name] = time.process_time() - c
    print("numba first call (compile) in this process, CPU s: "
          + ", ".join(f"{k} {v:.2f}" for k, v in first.items()), flush=True)
    m1 = mujoco.MjModel.from_xml_path(str(ROOT / "models" / "quarter_car.xml"))
    d1 = mujoco.MjData(m1)
    raw_xml = best(lambda: mujoco.mj_step(m1, d1, nstep=20000), 3) / 20000
    cases = [(1, 2.0 if QUICK else 10.0, "skyhook"), (1, 2.0 if QUICK else 10.0, "adaptive"),
             (64, 2.0, "adaptive"), (256, 1.0 if QUICK else 2.0, "adaptive")]
    rows = []
    for n, dur, ctrl in cases:
        r = measure(n, dur, ctrl, repeats=3 if n > 1 else 5)
        rows.append(r)
        print(f"  measured {n} car(s) x {dur} s, {ctrl}: done", flush=True)
    us = 1e6
    print(f"\nraw mj_step(nstep) of models/quarter_car.xml alone: {raw_xml * us:.2f} µs/step "
          f"({DT / raw_xml:.0f}x real time)\n")
    hdr = (f"{'case':<26}{'variant':<46}{'µs/car-step':>12}{'RTF/core':>10}{'÷ nstep':>9}")
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        case = f"{r['n']} car{'s' if r['n'] > 1 else ''} x {r['duration']:g} s {r['ctrl']}"
        items = [("(a) mj_step, Python loop", r["py"]), ("(a) mj_step(nstep) C loop", r["nstep"]),
                 ("(a) mj_step1+2, numba loop, nothing else", r["bare"]),
                 ("(b) compiled closed loop (ctypes)", r["b"]), ("(b) compiled closed loop (by symbol)", r["bx"]),
                 ("(b') compiled plant/effects, Python controller", r["h"]),
                 ("(b) + today's results/metrics (end to end)", r["b"] + r["c_res"]),
                 ("(c) suspension_sim loop", r["c_loop"]), ("(c) ... + results/metrics", r["c_total"])]
        for lab, v in items:
            print(f"{case:<26}{lab:<46}{v * us:>12.3f}{DT / v:>10.0f}{v / r['nstep']:>9.2f}")
            case = ""
        print(f"{'':<26}(c)/(b) = {r['c_loop'] / r['b']:.0f}x; (b) vs (c) max rel. deviation: "
              + ", ".join(f"{k} {v:.1e}" for k, v in r["dev"].items())
              + (" (bit-identical)" if r["bitwise"] else "") + f"; travel beyond stops {r['stops'] * 100:.0f} %")
        print(f"{'':<26}(b') vs (b): max rel. deviation {r['dev_h']:.1e}; the Python controller's own call: "
              f"{r['ctrl_call'] * us:.1f} µs per control step; precomputing the road array (not in (b)): "
              f"{r['road'] * us:.3f} µs/car-step")
    print("\nthe thesis MRAC (bench_speed.py) as a Python controller: "
          + ", ".join(f"{n} car(s) {mrac_call_cost(n) * us:.0f} µs per call" for n in (1, 256)))
    print("\nraw mj_step(nstep), 256-car ensemble, model variants (what bounds the batch target):")
    for label, nv, v in raw_model_variants():
        print(f"  {label:<52} dof/car {nv}  {v * us:.3f} µs/car-step  {DT / v:6.0f}x real time")
    print("\nnumba compile (first call, wall s, tiny case, fresh process) and cache=True:")
    for label, v, warn in cache_check():
        if v is None:
            print(f"  {label}: failed: {warn}")
            continue
        tc, te, hc, he = v
        print(f"  {label:<20} ctypes kernel {tc:6.2f} s (cache hit: {hc}),  by-symbol kernel {te:6.2f} s "
              f"(cache hit: {he})" + (f"   [{warn[0][:160]}]" if warn else ""))


if __name__ == "__main__":
    if "--probe" in sys.argv:
        _register_adaptive()
        compile_probe()
    else:
        main()
