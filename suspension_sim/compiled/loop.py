"""The compiled closed loop (see the package docstring for the kernel protocol).

:func:`plan` decides whether a :class:`~suspension_sim.simulation.Simulation` can run compiled and how:

- ``"full"``: every effect and the actuator have kernels, and so have the controller and every sensor: one
  numba call runs a whole road chunk (2000 physics steps), MuJoCo included;
- ``"hybrid"``: effects and actuator compiled, the controller (or a sensor, or full-state access) stays in
  Python: the compiled loop returns at each control instant, Python reads the sensors and calls the
  controller exactly as the Python loop does, and the compiled loop goes on with the command;
- ``None`` (with the reason): the Python loop of ``loop.py`` runs (an effect or actuator without a
  kernel, or ``SUSPENSION_SIM_COMPILED=0``).  Manoeuvre loads are computed per chunk in Python and added
  by the loop.  Time-varying parameters are applied from Python
  before each control instant (the loop returns there).

For each combination of component kernels a small module is generated (the loop with the kernels' calls
written out, so numba inlines them) into a cache folder, and compiled with ``cache=True``: the first run of a
combination compiles it (3–5 s), later runs and processes load it from disk (~0.25 s).  The folder is
``$SUSPENSION_SIM_CACHE`` or ``~/.cache/suspension_sim``; when it is not writable, a temporary folder is used
(compiled again in each process).

The loop does what ``loop.steps`` does, in the same order and with the same arithmetic, so the
results are the same (the tests compare the two loops value by value).
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
import tempfile
import textwrap
import threading
import time as _time
from pathlib import Path

import mujoco
import numpy as np

from .. import buffers
from ..numba_cache import compile_lock

TEMPLATE_VERSION = 24

# PlantState fields a compiled sensor may read (Sensor.kernel_field), by code
FIELDS = ("body_pos", "body_vel", "body_acc", "corner_body_pos", "corner_body_vel", "corner_body_acc",
          "wheel_pos", "wheel_vel", "wheel_acc", "travel", "travel_rate", "road", "road_vel", "tire_force",
          "actuator_force", "actuator_state", "body_acc_mean", "corner_body_acc_mean", "wheel_acc_mean")
PRE = 1 << 40  # the loop's return code before a control instant with time-varying parameters (PRE + k)
# rows of the per-quantity log column table
LOG_ROWS = ("body_pos", "body_vel", "body_acc", "travel", "travel_rate", "wheel_z", "wheel_vel", "tire_force",
            "tire_effect_force", "road", "road_vel", "command", "actuator_force", "effect_force", "wheel_acc")
_BAD_WARNINGS = (mujoco.mjtWarning.mjWARN_BADCTRL, mujoco.mjtWarning.mjWARN_BADQACC,
                 mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQPOS)


def _kernel_ref(fn):
    """(module, name) of a module-level numba function, or None."""
    py = getattr(fn, "py_func", None)
    if py is None or "<locals>" in py.__qualname__:
        return None
    mod = sys.modules.get(py.__module__)
    if mod is None or getattr(mod, py.__qualname__, None) is not fn:
        return None
    return py.__module__, py.__qualname__


def plan(sim) -> tuple[str | None, str]:
    """("full" | "hybrid" | None, reason) for a built Simulation."""
    if os.environ.get("SUSPENSION_SIM_COMPILED", "1").strip().lower() in ("0", "false", "no", "off"):
        return None, "SUSPENSION_SIM_COMPILED=0"
    from . import mj

    if mj.load() is not None:
        return None, mj.load()
    for eff, _ in sim.effects:
        if type(eff).kernel is None or _kernel_ref(type(eff).kernel) is None:
            return None, f"effect {eff.name!r} has no kernel"
    act = sim.actuator
    if type(act).kernel_force is None or _kernel_ref(type(act).kernel_force) is None \
            or _kernel_ref(type(act).kernel_advance) is None:
        return None, f"actuator {act.name!r} has no kernel"
    ctrl = sim.controller
    if sim.full_state:
        return "hybrid", "full-state access"
    if type(ctrl).kernel is None or _kernel_ref(type(ctrl).kernel) is None:
        return "hybrid", f"controller {ctrl.name!r} has no kernel"
    for ch in sim.sensors:
        if ch.sensor.kernel_field() is None:
            return "hybrid", f"sensor {ch.name!r} has no kernel"
    return "full", ""


# ----------------------------------------------------------------------------------------------------------
# code generation
# ----------------------------------------------------------------------------------------------------------
def _source_digest() -> str:
    """Hash of the sources the generated modules depend on (numba's cache does not track callees)."""
    global _DIGEST
    if _DIGEST is None:
        h = hashlib.sha256(str(TEMPLATE_VERSION).encode())
        root = Path(__file__).resolve().parents[2]
        for sub in ("suspension_sim/effects", "suspension_sim/actuators", "suspension_sim/compiled", "suspension_sim/sensors",
                    "controllers"):
            for f in sorted((root / sub).glob("*.py")):
                h.update(f.name.encode())
                h.update(f.read_bytes())
        import numba

        h.update(numba.__version__.encode())
        h.update(mujoco.__version__.encode())
        _DIGEST = h.hexdigest()[:16]
    return _DIGEST


_DIGEST = None
_MODULES: dict = {}
_LOAD_LOCK = threading.Lock()


def _cache_dir() -> Path:
    base = os.environ.get("SUSPENSION_SIM_CACHE") or os.path.join(os.path.expanduser("~"), ".cache", "suspension_sim")
    d = Path(base) / "kernels"
    try:
        d.mkdir(parents=True, exist_ok=True)
        probe = d / f".probe{os.getpid()}"
        probe.write_text("")
        probe.unlink()
        return d
    except OSError:
        d = Path(tempfile.gettempdir()) / f"suspension_sim_kernels_{os.getuid() if hasattr(os, 'getuid') else 0}"
        d.mkdir(parents=True, exist_ok=True)
        return d


_FIELD_ARGS = ("i, jr, qpos, qvel, ten_len, ten_vel, acc, accm, body_q, body_v, wheel_q, wheel_v, susp_t, tire_t, has_tire, "
               "road_z, road_zd, kt, ct, Jb, F_act, F_teff, a_st, road_dof")


# the value of PlantState field code f for car i and column col (the sensor's Python pipeline reads the same
# numbers): one function per field that a sensor of the loop reads, so that a call site carries only its own
# field's code (one function of all fields, inlined at every sensor, made numba type and lower every field's
# branch per sensor: ~1 s of compiling per sensor)
_FIELD_CODE = {
    0: "return qpos[body_q[i, col]]",
    1: "return qvel[body_v[i, col]]",
    2: "return acc[body_v[i, col]]",  # the last step's acceleration
    16: "return accm[body_v[i, col]]",  # its period mean (sampling: period_mean)
    3: "return ten_len[susp_t[i, col]] + qpos[wheel_q[i, col]]",
    4: "return ten_vel[susp_t[i, col]] + qvel[wheel_v[i, col]]",
    5: "s = 0.0\nfor b in range(body_v.shape[1]):\n    s += Jb[i, col, b] * acc[body_v[i, b]]\nreturn s",
    17: "s = 0.0\nfor b in range(body_v.shape[1]):\n    s += Jb[i, col, b] * accm[body_v[i, b]]\nreturn s",
    6: "return qpos[wheel_q[i, col]]",
    7: "return qvel[wheel_v[i, col]]",
    8: "return acc[wheel_v[i, col]] if has_tire else 0.0",
    18: "return accm[wheel_v[i, col]] if has_tire else 0.0",
    9: "return ten_len[susp_t[i, col]]",
    10: "return ten_vel[susp_t[i, col]]",
    11: "return road_z[jr, i, col]",
    12: "return road_zd[jr, i, col]",
    13: ("if has_tire:\n    tl = ten_len[tire_t[i, col]]\n    tv = ten_vel[tire_t[i, col]]\n    if not road_dof:\n"
         "        tl = tl - road_z[jr, i, col]\n        tv = tv - road_zd[jr, i, col]\n"
         "    return -kt[i, col] * tl - ct[i, col] * tv + F_teff[i, col]\nreturn 0.0"),
    14: "return F_act[i, col]",
    15: "return a_st[i, col, aux]",
}


def _field_defs(fields) -> str:
    out = []
    for f in sorted(set(fields)):
        body = "".join(f"    {line}\n" for line in _FIELD_CODE[f].split("\n"))
        out.append(f'@njit(cache=True, inline="always")\ndef field_{f}(col, aux, {_FIELD_ARGS}):  # {FIELDS[f]}\n{body}\n\n')
    return "".join(out)


def _sensor_code(sc: int, field: int, simple: bool, layout=None) -> str:
    """The compiled loop's lines for sensor ``sc`` (reading PlantState field code ``field``), for car i: a
    sensor without delay, hold, noise or quantisation is read straight into y (its value + bias, as the
    Python pipeline computes it); else through the ring buffer of the pipeline.  ``layout``: (columns read,
    offset in y, auxiliary index) written into the lines as constants, or None: read from the arrays."""
    if layout is None:
        k, off, col, aux = f"sens_k[{sc}]", f"sens_off[{sc}]", f"sens_cols[{sc}, q]", f"sens_aux[{sc}]"
    else:
        cols, o, a = layout
        k, off, aux = str(len(cols)), str(int(o)), str(int(a))
        col = str(int(cols[0])) if len(cols) == 1 else f"{tuple(int(c) for c in cols)}[q]"
    val = f"field_{field}({col}, {aux}, {_FIELD_ARGS})"
    ind = " " * 16
    if simple:
        return (f"{ind}for q in range({k}):\n"
                f"{ind}    y[i, {off} + q] = {val} + sens_bias[{sc}]\n")
    return (f"{ind}for q in range({k}):\n"
            f"{ind}    ring[i, {sc}, sens_tmp[{sc}, 0], q] = {val}\n"
            f"{ind}if sens_tmp[{sc}, 2]:\n"
            f"{ind}    for q in range({k}):\n"
            f"{ind}        z = noise[i, sens_tmp[{sc}, 3] + q] if sens_std[{sc}] > 0 else 0.0\n"
            f"{ind}        y[i, {off} + q] = measure(ring[i, {sc}, sens_tmp[{sc}, 1], q], sens_bias[{sc}], z, "
            f"sens_q[{sc}])\n")


# the loop's run-time switches that a specialised module (generate_source's ``spec``) has as constants
SPEC_FLAGS = ("has_man", "road_dof", "rk4", "trap", "has_tire", "has_effects", "has_tire_effects")


def generate_source(effects, actuator, controller, sensors=(), shape=None, spec=None) -> str:
    """Python source of the loop for ``effects`` [(module, name, target, reads the actuator force)], ``actuator`` ((module, force),
    (module, advance)) and ``controller`` ((module, name) or None for the hybrid loop; (module, name, True): its
    kernel runs for four cars per call where they share a parameter row, see :mod:`suspension_sim.compiled.lanes`).
    ``shape``: (corners, body dofs) per car, written into the loop as constants (or None: read from the arrays).

    Constant corner and body-dof counts let LLVM unroll the loops over them (a quarter car's are of length 1),
    and the actuator's kernels are inlined at numba's level (:func:`inlined`; LLVM left the actuator's force
    out of line in the loop's large function, a call with ~20 arguments through memory per car and step):
    together ~6 % off the loop's time in the benchmark batch.  Neither changes an operation or its order.

    ``spec`` (or None): (flags, log columns, sensor layouts) written into the loop as constants: ``flags`` the
    values of :data:`SPEC_FLAGS` (the plant's, integrator's and manoeuvre's switches), ``log columns`` the
    plant's log column table (``_Layout.LC``, as tuples; None: read from the argument) and ``sensor layouts``
    one (columns, offset in y, auxiliary index) per sensor (None: read from the arrays).  The loop's branches
    on them and their table loads go (LLVM folds them): ~3 % of the benchmark loop's time (issue 15, twelfth
    session); no operation on a number changes.  The arguments are still passed (and ignored): the caller's
    values must be the ones the module was generated for (``run_steps`` keys the module on them)."""
    imp = ["import numpy as np", "from numba import njit",
           "from suspension_sim.compiled.mj import mj_step1, mj_step2, mj_step, mj_forwardSkip",
           "from suspension_sim.compiled.loop import inlined",
           "from suspension_sim.sensors.base import measure, period_mean_acc", "from suspension_sim.compiled.views import row"]
    for k, (mod, name, _, _) in enumerate(effects):  # inlined at numba's level, as the actuator's kernels
        imp.append(f"from {mod} import {name} as _eff{k}")
        imp.append(f"eff{k} = inlined(_eff{k})")
    (am, af), (am2, aa) = actuator
    imp.append(f"from {am} import {af} as _act_force")
    imp.append(f"from {am2} import {aa} as _act_advance")
    imp.append("act_force = inlined(_act_force)")
    imp.append("act_advance = inlined(_act_advance)")
    shape_code = ("    n, nc = road_q.shape\n    nb = body_q.shape[1]\n" if shape is None else
                  f"    n = road_q.shape[0]\n    nc = {int(shape[0])}  # the module is generated for this shape\n"
                  f"    nb = {int(shape[1])}\n"
                  "    if road_q.shape[1] != nc or body_q.shape[1] != nb:\n"
                  "        raise ValueError('compiled loop generated for another number of corners or body dofs')\n")
    flags, lc_const, sens_layout = spec if spec is not None else (None, None, None)
    if flags is not None:
        shape_code += "".join(f"    {nm} = {bool(v)}  # the module is generated for this value\n"
                              for nm, v in zip(SPEC_FLAGS, flags))
    lc = "LC"
    if lc_const is not None:  # a module-level array: a constant to numba (and its loads to LLVM)
        imp.append(f"LCK = np.array({[list(map(int, r)) for r in lc_const]!r}, dtype=np.int64)")
        lc = "LCK"
    lanes = controller is not None and len(controller) > 2 and bool(controller[2])
    if controller is not None:
        imp.append(f"from {controller[0]} import {controller[1]} as ctrl_kernel")
    if lanes:
        imp.append("from suspension_sim.compiled.lanes import block4, block_rows, blocked_get, interleave_blocks, lane_block, lanes4")
    eargs = "".join(f", e{k}_p, e{k}_st, e{k}_map, e{k}_sigj, e{k}_lc, e{k}_pi" for k in range(len(effects)))
    susp_calls, tire_calls, sig_logs = [], [], []
    for k, (_, _, target, reads_fa) in enumerate(effects):
        ind = " " * (24 if target == "tire" else 20)
        call = (f"{ind}jj = e{k}_map[c]\n"
                f"{ind}if jj >= 0:\n"
                f"{ind}    {'f' if target != 'tire' else 'ft'} += eff{k}("
                f"{'s, v' if target != 'tire' else 'tl, tv'}, t, dt, row(row(e{k}_p, e{k}_pi[i]), jj), row(row(e{k}_st, i), jj)"
                f"{', Fa' if reads_fa else ''})\n")  # Fa: this step's actuator force (Effect.reads_actuator_force)
        (tire_calls if target == "tire" else susp_calls).append(call)
        sig_logs.append(
            f"                for q in range(e{k}_sigj.shape[0]):\n"
            f"                    for jj in range(e{k}_lc.shape[1]):\n"
            f"                        Lr[e{k}_lc[q, jj]] = e{k}_st[i, jj, e{k}_sigj[q]]\n")
    # the control stage of car i before its kernel: its sensors, then its command row zeroed
    sensor_block = "".join(_sensor_code(sc, f, simple, None if sens_layout is None else sens_layout[sc])
                           for sc, (f, simple) in enumerate(sensors)) + \
        "                for c in range(nc):\n                    cmd[i, c] = 0.0\n"
    acc_pass = _acc_code(" " * 20)

    def acc_flush(ind):  # the last step's acceleration, before the loop returns
        return (f"{ind}if acc_due:\n{ind}    for i in range(n):\n" + _acc_code(ind + " " * 8)
                + f"{ind}    acc_due = False\n")

    ctrl_block = ("                ctrl_kernel(t, row(y, i), row(c_p, c_pi[i]), row(c_st, i), row(cmd, i))\n" if controller is not None
                  else "")
    if lanes:  # four cars that share the controller's parameter row in one call (compiled.lanes): their sensors
        # first, then the kernel lane by lane; each car's stages read only that car's data, so reading cars
        # i+1..i+3 before car i's forces changes no number
        per_car = sensor_block + ctrl_block
        quad = re.sub(r"\bi\b", "i4", sensor_block)
        four = ", ".join(f"row({{a}}, i + {j})" for j in range(4))
        ctrl_head = (
            "                blk = lane_block(c_pi, i, n)\n"
            "                if blk and i % 4 == 0:\n"
            "                    for i4 in range(i, i + 4):\n"
            + textwrap.indent(quad, " " * 8)
            + f"                    ctrl_kernel(t, lanes4({four.format(a='y')}), row(c_p, c_pi[i]), block4(block_rows(c_st, i // 4)), "
              f"lanes4({four.format(a='cmd')}))\n"
            "                elif not blk:\n" + textwrap.indent(per_car, " " * 4))
        sensor_block, ctrl_block = ctrl_head, ""
    def unblock(ind):  # before the loop returns: every car's controller state back in its own row
        return " " * ind + "interleave_blocks(c_st, c_pi, n, False)\n" if lanes else ""

    acc_read = any(f in (FIELDS.index("body_acc"), FIELDS.index("corner_body_acc"), FIELDS.index("wheel_acc"))
                   for f, _ in sensors)
    mean_read = any(FIELDS[f].endswith("_acc_mean") for f, _ in sensors)
    field_defs = _field_defs(f for f, _ in sensors)
    body = f'''
PRE = {PRE}
ACC_READ = {acc_read}  # a sensor reads an acceleration
MEAN_READ = {mean_read}  # a sensor reads a period-mean acceleration


{field_defs}@njit(cache=True, nogil=True)
def loop(m_addr, d_addr, qpos, qvel, ctrl, ten_len, ten_vel, warn, warn_idx,
         road_q, road_v, road_servo, susp_t, tire_t, eff_s, eff_t, act, wheel_q, wheel_v, body_q, body_v,
         free_q, free_v, has_tire, has_effects, has_tire_effects, kt, ct, Jb, road_dof, lsp, rest0, tire_ct,
         rk4, qfrc, qacc, road_mass, trap, half_cs, half_ct, v_prev, has_man, pitch_v, roll_v, acc_dofs, v_ctrl, accm,
         acc_period,
         road_z, road_zd, road_zdd, man_p, man_r, k_chunk0, k0, k1, resume, var_hook, full_control, n_steps, sub, log_every, dt, lim_x, lim_v,
         cmd, F_act, F_eff, F_teff, acc, v_before, sv, a_p, a_pi, a_st,
         sens_field, sens_cols, sens_aux, sens_off, sens_k, sens_delay, sens_hold, sens_bias, sens_std, sens_q,
         noise, noise_off, ring, sens_tmp, y, kc_arr, c_p, c_pi, c_st,
         L, log0, LC, lc_act, act_j, lc_y, y_j, lc_ctrl, ctrl_j{eargs}):
    """Physics steps k0..k1-1 (road samples of step k at road_z[k - k_chunk0]).  Returns k1 when done,
    k (>= 0) at a control instant that Python must handle (hybrid loop, after mj_step1 of step k: call again
    with resume=1 from k), -(k + 1) when the state check at control instant k fails, or PRE + k before
    control instant k when var_hook is set (Python applies the time-varying parameters, then calls again with
    resume=2 from k).  Log row j (step j * log_every) goes to L[j - log0]: L (rows, cars, channels) holds log
    rows log0 .. log0 + L.shape[0] - 1 (one chunk of the log; the caller stops at its end and flushes it).

    Between mj_step1 and mj_step2 one pass over the cars does, car by car, what the Python loop does for
    all cars in turn (sensors and controller at a control instant, the trapezoidal coupling, actuator and
    effect forces, the log, the actuator's advance): every step of a car reads only that car's data, so the
    order across cars does not change a number, and each car's data is fetched once per step instead of
    once per stage."""
{shape_code}    n_log = L.shape[0]
{"    interleave_blocks(c_st, c_pi, n, True)  # lane blocks' controller states interleaved while the loop runs" + chr(10) if lanes else ""}    k = k0
    skip = resume == 1
    pre_done = resume == 2
    # the acceleration of a step that needs it (need_acc) is computed, and logged, at the start of the next
    # step's pass over the cars (before mj_step1: qvel is the step's result, untouched) or before the loop
    # returns, instead of in a pass of its own after mj_step2 (RK4: after its step, as before)
    acc_due = False
    acc_log = False
    acc_jl = 0
    while k < k1:
        t = k * dt
        jr = k - k_chunk0
        if var_hook and not skip and not pre_done and k % sub == 0:
{acc_flush(" " * 12)}{unblock(12)}            return PRE + k
        pre_done = False
        ctrl_now = False
        kc = 0
        if not skip:
            if has_man:  # the manoeuvre's loads of this step (loop.steps: zero, then AppliedManeuver.apply)
                for q in range(qfrc.shape[0]):
                    qfrc[q] = 0.0
                for i in range(n):
                    if pitch_v[i] >= 0:
                        qfrc[pitch_v[i]] += man_p[jr, i]
                    if roll_v[i] >= 0:
                        qfrc[roll_v[i]] += man_r[jr, i]
            for i in range(n):
                if acc_due:
{acc_pass}                for c in range(nc):
                    z = road_z[jr, i, c]
                    if road_dof:
                        qpos[road_q[i, c]] = z
                        qvel[road_v[i, c]] = road_zd[jr, i, c]
                        ctrl[road_servo[i, c]] = z
                        if rk4:  # the heavy plates get the road's acceleration within the RK4 stages
                            qfrc[road_v[i, c]] = road_mass * road_zdd[jr, i, c]
                    else:  # the road as the tire spring's rest length (Plant.place_road)
                        lsp[tire_t[i, c], 0] = rest0[i, c, 0] + z
                        lsp[tire_t[i, c], 1] = rest0[i, c, 1] + z
            acc_due = False
            mj_step1(m_addr, d_addr)
            if k % sub == 0:
                bad = False
                for w in range(warn_idx.shape[0]):
                    if warn[warn_idx[w]] > 0:
                        bad = True
                for q in range(free_q.shape[0]):
                    if not abs(qpos[free_q[q]]) <= lim_x:
                        bad = True
                for q in range(free_v.shape[0]):
                    if not abs(qvel[free_v[q]]) <= lim_v:
                        bad = True
                if bad:
{unblock(20)}                    return -(k + 1)
                if MEAN_READ or not full_control:  # read by the sensors (Python's, in the hybrid loop)
                    period_mean_acc(qvel, v_ctrl, acc_dofs, acc_period, accm)  # as loop.steps, before the sensors
                if not full_control:
{unblock(20)}                    return k
                # sensors: true value -> delay -> bias + noise -> quantisation -> sample-and-hold
                kc = kc_arr[0]
                ns = sens_field.shape[0]
                for sc in range(ns):  # ring slots, hold and noise index of this control step (same for all cars)
                    nr = sens_delay[sc] + 1
                    old = kc - sens_delay[sc] if kc >= sens_delay[sc] else 0
                    sens_tmp[sc, 0] = kc % nr
                    sens_tmp[sc, 1] = old % nr
                    sens_tmp[sc, 2] = 1 if kc % sens_hold[sc] == 0 else 0
                    sens_tmp[sc, 3] = noise_off[sc] + (kc // sens_hold[sc]) * sens_k[sc]
                ctrl_now = True
        skip = False
        log_now = k % log_every == 0
        jl = k // log_every - log0
        logw = log_now and 0 <= jl < n_log
        # the acceleration of this step is read by the log, by sensors at the next control instant (a sensor
        # of an acceleration, or Python's sensors in the hybrid loop) and after the last step (sim.end_forces)
        need_acc = log_now or k == n_steps - 1 or ((k + 1) % sub == 0 and (ACC_READ or not full_control))
        for i in range(n):
            if ctrl_now:
{sensor_block}{ctrl_block}            if trap:  # body-wheel damper coupling from the last step's velocity change (loop.trapezoidal_coupling)
                for b in range(nb):
                    fb = 0.0
                    for c in range(nc):
                        fb += (half_cs[i, c] * Jb[i, c, b]) * (qvel[wheel_v[i, c]] - v_prev[wheel_v[i, c]])
                    if has_man:
                        qfrc[body_v[i, b]] += fb
                    else:
                        qfrc[body_v[i, b]] = fb
                for c in range(nc):
                    sw = 0.0
                    for b in range(nb):
                        sw += Jb[i, c, b] * (qvel[body_v[i, b]] - v_prev[body_v[i, b]])
                    if has_man:
                        qfrc[wheel_v[i, c]] += half_cs[i, c] * sw
                    else:
                        qfrc[wheel_v[i, c]] = half_cs[i, c] * sw
                for b in range(nb):
                    v_prev[body_v[i, b]] = qvel[body_v[i, b]]
                for c in range(nc):
                    v_prev[wheel_v[i, c]] = qvel[wheel_v[i, c]]
            # forces from the state at the start of the step
            for c in range(nc):
                s = ten_len[susp_t[i, c]]
                v = ten_vel[susp_t[i, c]]
                sv[i, c, 0] = s
                sv[i, c, 1] = v
                Fa = act_force(cmd[i, c], s, v, t, dt, row(row(a_p, a_pi[i]), c), row(row(a_st, i), c))
                F_act[i, c] = Fa
                if has_effects:
                    f = 0.0
                    ft = 0.0
                    if has_tire_effects:
                        tl = ten_len[tire_t[i, c]]
                        tv = ten_vel[tire_t[i, c]]
                        if not road_dof:
                            tl = tl - road_z[jr, i, c]
                            tv = tv - road_zd[jr, i, c]
{''.join(tire_calls) if tire_calls else "                        pass" + chr(10)}{''.join(susp_calls)}                    F_eff[i, c] = f
                    F_teff[i, c] = ft
                    if not trap:  # (the trapezoidal scheme's lines below write both)
                        ctrl[eff_s[i, c]] = f
                        if has_tire and road_dof:
                            ctrl[eff_t[i, c]] = ft
                if trap:  # the explicit half of the linear dampers (loop.steps)
                    ctrl[eff_s[i, c]] = F_eff[i, c] + (-half_cs[i, c] * v)
                    ctrl[eff_t[i, c]] = (F_teff[i, c] + tire_ct[i, c] * road_zd[jr, i, c]) + \\
                        (-half_ct[i, c] * ten_vel[tire_t[i, c]])
                elif not road_dof:
                    ctrl[eff_t[i, c]] = F_teff[i, c] + tire_ct[i, c] * road_zd[jr, i, c]
                ctrl[act[i, c]] = Fa
            if logw:
                # a channel that is not logged has column -1 (a batch without time series keeps only what
                # the metrics read): neither read nor written
                Lr = row(row(L, jl), i)
                for b in range(nb):
                    if LC[0, b] >= 0:
                        Lr[LC[0, b]] = qpos[body_q[i, b]]
                    if LC[1, b] >= 0:
                        Lr[LC[1, b]] = qvel[body_v[i, b]]
                for c in range(nc):
                    if LC[3, c] >= 0:
                        Lr[LC[3, c]] = ten_len[susp_t[i, c]]
                    if LC[4, c] >= 0:
                        Lr[LC[4, c]] = ten_vel[susp_t[i, c]]
                    if has_tire:
                        if LC[5, c] >= 0:
                            Lr[LC[5, c]] = qpos[wheel_q[i, c]]
                        if LC[6, c] >= 0:
                            Lr[LC[6, c]] = qvel[wheel_v[i, c]]
                        if LC[7, c] >= 0:
                            tl = ten_len[tire_t[i, c]]
                            tv = ten_vel[tire_t[i, c]]
                            if not road_dof:
                                tl = tl - road_z[jr, i, c]
                                tv = tv - road_zd[jr, i, c]
                            Lr[LC[7, c]] = -kt[i, c] * tl - ct[i, c] * tv + F_teff[i, c]
                        if LC[8, c] >= 0:
                            Lr[LC[8, c]] = F_teff[i, c]
                    if LC[9, c] >= 0:
                        Lr[LC[9, c]] = road_z[jr, i, c]
                    if LC[10, c] >= 0:
                        Lr[LC[10, c]] = road_zd[jr, i, c]
                    if LC[11, c] >= 0:
                        Lr[LC[11, c]] = cmd[i, c]
                    if LC[12, c] >= 0:
                        Lr[LC[12, c]] = F_act[i, c]
                    if LC[13, c] >= 0:
                        Lr[LC[13, c]] = F_eff[i, c]
                for q in range(act_j.shape[0]):
                    for c in range(nc):
                        Lr[lc_act[q, c]] = a_st[i, c, act_j[q]]
                for q in range(lc_y.shape[0]):
                    Lr[lc_y[q]] = y[i, y_j[q]]
                for q in range(lc_ctrl.shape[0]):
                    Lr[lc_ctrl[q]] = {"blocked_get(c_st, i, ctrl_j[q], lane_block(c_pi, i, n))" if lanes else "c_st[i, ctrl_j[q]]"}
{''.join(sig_logs)}            if need_acc and not rk4:
                for b in range(nb):
                    v_before[body_v[i, b]] = qvel[body_v[i, b]]
                if has_tire:
                    for c in range(nc):
                        v_before[wheel_v[i, c]] = qvel[wheel_v[i, c]]
            # the actuator's state for the next step (MuJoCo's step does not read it: advanced before the step
            # as after it)
            for c in range(nc):
                act_advance(cmd[i, c], sv[i, c, 0], sv[i, c, 1], t, dt, row(row(a_p, a_pi[i]), c), row(row(a_st, i), c))
        if ctrl_now:
            kc_arr[0] = kc + 1
        if rk4:
            if need_acc:  # the acceleration at the step start, with this step's forces
                mj_forwardSkip(m_addr, d_addr, 2, 1)
                for i in range(n):
                    for b in range(nb):
                        acc[body_v[i, b]] = qacc[body_v[i, b]]
                    if has_tire:
                        for c in range(nc):
                            acc[wheel_v[i, c]] = qacc[wheel_v[i, c]]
            mj_step(m_addr, d_addr)
        else:
            mj_step2(m_addr, d_addr)
        if need_acc:
            if rk4:
                if logw:
                    for i in range(n):
                        Lr = row(row(L, jl), i)
                        for b in range(nb):
                            if LC[2, b] >= 0:
                                Lr[LC[2, b]] = acc[body_v[i, b]]
                        if has_tire:
                            for c in range(nc):
                                if LC[14, c] >= 0:
                                    Lr[LC[14, c]] = acc[wheel_v[i, c]]
            else:  # computed and logged at the start of the next step's pass, or before returning
                acc_due = True
                acc_log = logw
                acc_jl = jl
        k += 1
{acc_flush(" " * 4)}{unblock(4)}    return k1
'''
    if lc != "LC":  # every table load of the body, the acceleration pass's included
        body = re.sub(r"\bLC\[", lc + "[", body)
    return "\n".join(imp) + "\n" + body


def _acc_code(ind: str) -> str:
    """The loop's lines for car i's acceleration of the last step, (qvel - v_before) / dt on its body and wheel
    dofs, and its log entries in row acc_jl when that step logged (acc_log)."""
    return (f"{ind}for b in range(nb):\n"
            f"{ind}    acc[body_v[i, b]] = (qvel[body_v[i, b]] - v_before[body_v[i, b]]) / dt\n"
            f"{ind}if has_tire:\n"
            f"{ind}    for c in range(nc):\n"
            f"{ind}        acc[wheel_v[i, c]] = (qvel[wheel_v[i, c]] - v_before[wheel_v[i, c]]) / dt\n"
            f"{ind}if acc_log:\n"
            f"{ind}    Lr = row(row(L, acc_jl), i)\n"
            f"{ind}    for b in range(nb):\n"
            f"{ind}        if LC[2, b] >= 0:\n"
            f"{ind}            Lr[LC[2, b]] = acc[body_v[i, b]]\n"
            f"{ind}    if has_tire:\n"
            f"{ind}        for c in range(nc):\n"
            f"{ind}            if LC[14, c] >= 0:\n"
            f"{ind}                Lr[LC[14, c]] = acc[wheel_v[i, c]]\n")


def inlined(kernel):
    """A component's kernel (a numba dispatcher) as a function that numba inlines into the generated loop at its
    own level (``inline="always"``: the kernel's code is copied into the loop's before LLVM sees it), with the
    kernel's other options.  Never compiled by itself: only the loop that calls it is (and cached)."""
    from numba import njit

    opts = {k: v for k, v in kernel.targetoptions.items() if k not in ("cache", "inline", "nopython")}
    return njit(inline="always", **opts)(kernel.py_func)


def load_module(effects, actuator, controller, sensors=(), shape=None, spec=None):
    """The compiled loop module for this combination (generated, written and imported once per process; the
    loop releases the GIL, so threads may run simulations side by side); ``shape`` and ``spec`` as
    :func:`generate_source`."""
    key = (tuple(effects), actuator, controller, tuple(sensors), shape, spec)
    mod = _MODULES.get(key)
    if mod is not None:
        return mod
    with _LOAD_LOCK:  # threads (diagnose fits candidates in parallel) import and compile a module once
        mod = _MODULES.get(key)
        if mod is not None:
            return mod
        src = generate_source(effects, actuator, controller, sensors, shape, spec)
        h = hashlib.sha256((_source_digest() + src).encode()).hexdigest()[:20]
        name = f"suspension_sim_loop_{h}"
        path = _cache_dir() / f"{name}.py"
        if not path.exists() or path.read_text() != src:
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(src)
            os.replace(tmp, path)  # atomic: parallel workers may write the same file
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
        _MODULES[key] = mod
    return mod


def _shared_rows(a):
    """(rows, index): the distinct rows of a kernel's per-car parameter block ``a`` (n_cars, ...), compared bit
    for bit, and each car's row in them (``rows[index[i]]`` is ``a[i]``; the loop reads ``row(rows, index[i])``).
    The cars of a batch mostly share their components' parameters (often only the road differs): one row read
    by all cars stays in the L1 cache, where a row per car (the MRAC's is 1.2 KB) is fetched from further out
    at every call, evicted by MuJoCo's step of the whole ensemble.  The same numbers are read: results are
    unchanged.  ``p`` is read-only for the kernels (the protocol); an effect's time-varying parameters rewrite
    its ``p`` during a run, so those are not shared (the caller's choice)."""
    n = a.shape[0]
    flat = a.reshape(n, -1)
    if n <= 1 or flat.shape[1] == 0:
        return np.ascontiguousarray(a[:1]), np.zeros(n, np.int64)
    keys = np.ascontiguousarray(flat).view(np.dtype((np.void, flat.shape[1] * flat.itemsize))).reshape(n)
    _, first, index = np.unique(keys, return_index=True, return_inverse=True)
    return np.ascontiguousarray(a[first]), np.ascontiguousarray(index.reshape(n), dtype=np.int64)


def _logged(lc, scratch, *src):
    """The rows of the log column table ``lc`` (one row per source: a column, or a column per corner) that log at
    least one column other than ``scratch``, and the same rows of each source index array in ``src``."""
    lc = np.asarray(lc, dtype=np.int64)
    keep = (lc != scratch).reshape(len(lc), -1).any(axis=1) if len(lc) else np.zeros(0, bool)
    return np.ascontiguousarray(lc[keep]), tuple(np.ascontiguousarray(np.asarray(j, dtype=np.int64)[keep]) for j in src)


def _lanes_on() -> bool:
    return os.environ.get("SUSPENSION_SIM_LANES", "1").strip().lower() not in ("0", "false", "no", "off")


def _i64(a):
    return np.ascontiguousarray(np.asarray(a, dtype=np.int64))


def _f64(a):
    return np.ascontiguousarray(np.asarray(a, dtype=np.float64))


class _Layout:
    """Log channel names in the order of log.Logger, and the column tables the kernel writes through."""

    def __init__(self, sim):
        from ..channels import body_channels

        P = sim.plant
        self.names: list[str] = []
        nb, nc = len(P.body_joints), P.nc
        self.LC = np.full((len(LOG_ROWS), max(nb, nc)), -1, dtype=np.int64)
        self.sfx = P.suffixes
        self._body = [body_channels(jn) for jn in P.body_joints]
        for k, (pn, vn, _) in enumerate(self._body):
            self.LC[0, k] = self._add(pn)
            self.LC[1, k] = self._add(vn)
        self._corner("travel", 3)
        self._corner("travel_rate", 4)
        if P.has_tire:
            self._corner("wheel_z", 5)
            self._corner("wheel_vel", 6)
            self._corner("tire_force", 7)
            self._corner("tire_effect_force", 8)
        for base, row in (("road", 9), ("road_vel", 10), ("command", 11), ("actuator_force", 12),
                          ("effect_force", 13)):
            self._corner(base, row)

    def _add(self, name):
        self.names.append(name)
        return len(self.names) - 1

    def _corner(self, base, row):
        for c, s in enumerate(self.sfx):
            self.LC[row, c] = self._add(f"{base}{s}")

    def add_rest(self, sim, act_names, reading_widths, ctrl_widths, eff_sigs):
        """Actuator states, sensor readings, controller and effect signals, then the accelerations."""
        P = sim.plant
        nc = P.nc
        self.lc_act = np.array([[self._add(f"act.{nm}{s}") for s in self.sfx] for nm in act_names],
                               dtype=np.int64).reshape(len(act_names), nc)
        cols = []
        for name, width in reading_widths:
            labels = sim.cctx.sensors.get(name) or [str(i) for i in range(width)]
            for c in range(width):
                lab = labels[c] if c < len(labels) else str(c)
                cols.append(self._add(f"sensor.{name}.{lab}" if lab else f"sensor.{name}"))
        self.lc_y = np.array(cols, dtype=np.int64)
        cols = []
        for name, width in ctrl_widths:
            cols += [self._add(f"ctrl.{name}")] if width == 1 else [self._add(f"ctrl.{name}.{c}") for c in range(width)]
        self.lc_ctrl = np.array(cols, dtype=np.int64)
        self.eff_lc = []
        for eff_name, sig_names, n_sel in eff_sigs:
            self.eff_lc.append(np.array([[self._add(f"effect.{eff_name}.{nm}.{c}") for c in range(n_sel)]
                                         for nm in sig_names], dtype=np.int64).reshape(len(sig_names), n_sel))
        for k, (_, _, an) in enumerate(self._body):
            self.LC[2, k] = self._add(an)
        if P.has_tire:
            self._corner("wheel_acc", 14)

    def keep_only(self, keep) -> None:
        """Log only the channels in ``keep`` (a batch without time series needs only what the metrics read):
        in the table of the plant's channels (``LC``) the others get column -1 (the loop skips them: neither read
        nor written); in the tables of actuator states, readings, controller and effect signals they go to one
        scratch column, the last (those tables are trimmed to the rows that log something; see ``run_steps``)."""
        if keep is None:
            return
        kept = [j for j, name in enumerate(self.names) if name in keep]
        remap = np.full(len(self.names), len(kept), dtype=np.int64)
        remap[kept] = np.arange(len(kept))
        self.names = [self.names[j] for j in kept] + ["__scratch__"]
        for attr in ("lc_act", "lc_y", "lc_ctrl"):
            a = getattr(self, attr)
            setattr(self, attr, np.where(a >= 0, remap[np.maximum(a, 0)], a))
        self.eff_lc = [remap[a] for a in self.eff_lc]
        drop = np.full(len(remap), -1, dtype=np.int64)
        drop[kept] = np.arange(len(kept))
        self.LC = np.where(self.LC >= 0, drop[np.maximum(self.LC, 0)], -1)


def _maneuver_joints(sim):
    """(pitch dof, roll dof) per car for the manoeuvre's loads, -1 where absent."""
    n = sim.plant.n
    out = []
    for name in ("pitch", "roll"):
        idx = getattr(sim.maneuver, name, None) if sim.maneuver is not None else None
        out.append(np.full(n, -1, np.int64) if idx is None else _i64(idx))
    return out


def metric_channels(suffixes) -> set | None:
    """The log channels the registered metrics read (their declared ``ensemble_channels``), or None when a
    metric does not declare them (then everything is logged)."""
    from ..registry import METRICS

    out = set()
    for _, fn in METRICS.items():
        chans = getattr(fn, "ensemble_channels", None)
        if getattr(fn, "ensemble", None) is None or chans is None:
            return None
        for c in chans:
            out.update(c.format(s=s) for s in suffixes) if "{s}" in c else out.add(c)
    return out


class _Record:
    """A log buffer whose chunks nobody reads (:func:`run_steps` without a logger)."""

    def __init__(self, n_log, cap, log_every, dt):
        self.n_log, self.cap, self.base, self.log_every, self.dt = n_log, cap, 0, log_every, dt
        self.t = np.zeros(cap)
        self.ch: dict = {}

    def flush(self, rows=None):
        self.base += self.cap if rows is None else rows
        self.t[:] = (np.arange(self.base, self.base + self.cap) * self.log_every) * self.dt


def run(sim, mode: str, progress, logger) -> float:
    """Run ``sim`` with the compiled loop (``mode`` from :func:`plan`), recording into ``logger`` (a
    :class:`~suspension_sim.log.Logger`: its ``t`` and ``ch`` are written here) the log of the Python loop;
    returns the wall time (s) of the loop."""
    steps = run_steps(sim, mode, progress, logger)
    try:
        readings = next(steps)
        while True:  # hybrid: the controller in Python at each control instant
            readings = steps.send(sim.controller.step(sim.t, readings))
    except StopIteration as stop:
        return stop.value


def run_steps(sim, mode: str, progress=None, logger=None):
    """:func:`run` as a generator: in the hybrid mode it yields the sensor readings at each control instant
    (``sim.t``, ``sim.state`` set) and takes the command (n_cars, n_corners) by ``send`` (step-wise use, e.g.
    the reinforcement-learning envs of :mod:`suspension_sim.rl`); returns the wall time (``StopIteration.value``).
    Without a ``logger`` the log is kept in a bare record (``t``, ``ch``) nobody reads."""
    from ..errors import SimulationDiverged
    from ..loop import check_divergence, exchange, plant_state
    from ..sensors.base import PlantState  # noqa: F401  (documented type of sim.state)

    P = sim.plant
    m, d = P.model, P.data
    n, nc = P.n, P.nc
    full = mode == "full"
    sim.reset()
    ctrl = sim.controller
    if full:
        try:  # a controller may have no kernel for some settings (e.g. open loop's random signal)
            ctrl_data = ctrl.kernel_data()
        except NotImplementedError as exc:
            full, sim.loop = False, "hybrid"
            sim.loop_reason = f"controller {ctrl.name!r}: {exc}" if str(exc) else f"controller {ctrl.name!r} has no kernel here"

    # component data ----------------------------------------------------------------------------------
    effects, eff_args, eff_sigs, eff_pi = [], [], [], []
    for eff, sel in sim.effects:
        fn = type(eff).kernel
        mod, name = _kernel_ref(fn)
        effects.append((mod, name, eff.target, bool(eff.reads_actuator_force)))
        p, st = eff.kernel_arrays()  # the arrays set_param rewrites (time-varying effect parameters)
        cmap = np.full(nc, -1, dtype=np.int64)
        cmap[np.asarray(sel)] = np.arange(len(sel))
        sig = eff.kernel_signals()
        names = [nm for nm in eff.signals() if nm in sig]
        pe, pi = _f64(p), np.arange(n, dtype=np.int64)
        if not sim.variations:  # else set_param rewrites p during the run: the loop reads it as it is
            pe, pi = _shared_rows(pe)
        eff_args.append([pe, _f64(st), cmap, np.array([sig[nm] for nm in names], dtype=np.int64)])
        eff_pi.append(pi)
        eff_sigs.append((eff.label, names, len(sel)))
    act = sim.actuator
    actuator = (_kernel_ref(type(act).kernel_force), _kernel_ref(type(act).kernel_advance))
    a_p, a_st = (_f64(x) for x in act.kernel_data())
    a_p, a_pi = _shared_rows(a_p)
    a_idx = act.kernel_states()
    act_names = [nm for nm in act.states() if nm != "force"]
    missing = [nm for nm in act_names if nm not in a_idx]
    if missing:
        raise RuntimeError(f"actuator {act.name!r}: kernel_states() lacks {missing}")
    act_j = np.array([a_idx[nm] for nm in act_names], dtype=np.int64)

    # (module, name, lanes): lanes when the kernel runs four cars per call (Controller.kernel_lanes) and the
    # SUSPENSION_SIM_LANES switch is not off (the same numbers either way; the switch is for comparing them)
    controller = (*_kernel_ref(type(ctrl).kernel), bool(getattr(type(ctrl), "kernel_lanes", False)) and _lanes_on()) \
        if full else None

    # sensors (compiled pipeline, full mode) ------------------------------------------------------------
    ns = len(sim.sensors)
    n_control = -(-sim.n_steps // sim.sub)
    sens = dict(field=np.zeros(ns, np.int64), aux=np.zeros(ns, np.int64), off=np.zeros(ns, np.int64),
                k=np.zeros(ns, np.int64), delay=np.zeros(ns, np.int64), hold=np.ones(ns, np.int64),
                bias=np.zeros(ns), std=np.zeros(ns), q=np.zeros(ns), noise_off=np.zeros(ns, np.int64))
    reading_widths = []
    if full:
        cols_list, off, noff, draws = [], 0, 0, []
        for s_i, ch in enumerate(sim.sensors):
            fld, cols = ch.sensor.kernel_field()
            cols = list(cols)
            aux = 0
            if fld == "actuator_state":
                sname = ch.sensor.p.state
                if sname == "force":
                    fld = "actuator_force"
                elif sname in a_idx:
                    aux = a_idx[sname]
                else:
                    ch.sensor.read(plant_state(sim, 0.0, np.zeros((n, nc)), np.zeros((n, nc)), np.zeros(m.nv),
                                              np.zeros((n, nc)), np.zeros((n, nc))))  # raises the user error
                    raise RuntimeError(f"actuator state {sname!r} has no kernel index")
            kk = len(cols)
            sens["field"][s_i], sens["aux"][s_i], sens["off"][s_i], sens["k"][s_i] = FIELDS.index(fld), aux, off, kk
            sens["delay"][s_i], sens["hold"][s_i] = ch.delay_steps, ch.hold_steps
            sens["bias"][s_i], sens["std"][s_i], sens["q"][s_i] = ch.cfg.bias, ch.cfg.noise_std, ch.cfg.quantization
            cols_list.append(cols)
            reading_widths.append((ch.name, kk))
            if ch.cfg.noise_std > 0:
                nd = -(-n_control // ch.hold_steps)
                z = np.stack([np.asarray(ch.rng.normal(0.0, ch.cfg.noise_std, size=(n, kk)), dtype=float)
                              for _ in range(nd)], axis=1)  # the Python loop's draws, in its order
                sens["noise_off"][s_i] = noff
                draws.append(z.reshape(n, -1))
                noff += nd * kk
            off += kk
        maxk = max([len(c) for c in cols_list] + [1])
        sens_cols = np.zeros((ns, maxk), np.int64)
        for s_i, c in enumerate(cols_list):
            sens_cols[s_i, :len(c)] = c
        noise = _f64(np.concatenate(draws, axis=1)) if draws else np.zeros((n, 1))
        ytot = off
        maxd = int(sens["delay"].max()) if ns else 0
        ring = np.zeros((n, max(ns, 1), maxd + 1, maxk))
        c_p, c_st = (_f64(x) for x in ctrl_data)
        csig = ctrl.kernel_signals()
        ctrl_widths = [(nm, b - a) for nm, (a, b) in csig.items()]
        ctrl_j = np.array([j for a, b in csig.values() for j in range(a, b)], dtype=np.int64)
    else:
        sens_cols, noise, ring, ytot = np.zeros((ns, 1), np.int64), np.zeros((n, 1)), np.zeros((n, 1, 1, 1)), 0
        c_p, c_st, ctrl_widths, ctrl_j = np.zeros((n, 1)), np.zeros((n, 0)), [], np.zeros(0, np.int64)
    c_p, c_pi = _shared_rows(c_p)

    sens_tmp = np.zeros((max(ns, 1), 4), np.int64)
    sensor_code = [(int(sens["field"][j]), bool(sens["delay"][j] == 0 and sens["hold"][j] == 1 and sens["std"][j] == 0
                                                and sens["q"][j] == 0)) for j in range(ns)] if full else []
    from ..build import n_log_samples

    n_log = n_log_samples(sim.n_steps, sim.log_every)
    if logger is None:  # a bare record nobody reads, in chunks of at most 30 s
        logger = _Record(n_log, min(n_log, max(2, int(30.0 / (sim.log_every * sim.dt)))), sim.log_every, sim.dt)
    cap = logger.cap  # log rows the buffer holds (the whole log, or a chunk: see log.buffer_rows)
    layout = _Layout(sim)
    y = np.zeros((n, max(ytot, 1)))

    def make_log():
        layout.add_rest(sim, act_names, reading_widths, ctrl_widths, eff_sigs)
        keep = getattr(sim, "log_channels", "all")
        if isinstance(keep, str):
            if keep == "metrics":
                layout.keep_only(metric_channels(P.suffixes))
        else:  # a set of channel names (diagnose's engine logs only what its outputs are made of)
            layout.keep_only(set(keep))
        # step-major (log step, car, channel): a log step writes one contiguous block for all cars, car after
        # car (car-major rows, one per car a buffer apart, cost a cache miss per car and log step; channel-major
        # a cache line per channel); the channels are (car, log step) views, which the metrics gather into
        # contiguous rows (results._contiguous).  Every entry but the scratch column (never read) is written by
        # the loop, so the buffer may be an earlier run's that nothing references any more (buffers.empty: no
        # fresh pages to fault in and zero).
        # the tables of the actuator states, readings, controller and effect signals keep only what is logged
        # (a batch without time series logs none of them: ~30 loads and stores per car and log step less)
        scratch = len(layout.names) - 1 if layout.names and layout.names[-1] == "__scratch__" else -1
        tabs["lc_act"], (tabs["act_j"],) = _logged(layout.lc_act, scratch, act_j)
        tabs["lc_y"], (tabs["y_j"],) = _logged(layout.lc_y, scratch, np.arange(len(layout.lc_y), dtype=np.int64))
        tabs["lc_ctrl"], (tabs["ctrl_j"],) = _logged(layout.lc_ctrl, scratch, ctrl_j)
        eff_full = []
        for args, lc, pi in zip(eff_args, layout.eff_lc, eff_pi):
            lc, (sigj,) = _logged(lc, scratch, args[3])
            eff_full += args[:3] + [sigj, lc, pi]
        if scratch >= 0 and not any((a == scratch).any() for a in [tabs["lc_act"], tabs["lc_y"], tabs["lc_ctrl"]]
                                    + eff_full[4::6]):
            layout.names.pop()  # no table writes to the scratch column any more: the log has none
        L = buffers.empty((cap, n, len(layout.names)))
        return L, eff_full

    tabs = {}

    if full:
        L, eff_full = make_log()
        # the log's column table and the sensors' layout are known now: constants of the module (hybrid: the
        # layout is known at the first control instant, so the loop reads them from its arguments)
        spec_cols = tuple(tuple(int(v) for v in r) for r in layout.LC)
        spec_sens = tuple((tuple(int(c) for c in sens_cols[j, :sens["k"][j]]), int(sens["off"][j]), int(sens["aux"][j]))
                          for j in range(ns))
    else:
        spec_cols = spec_sens = None  # the layout needs the first readings and controller signals: built at the first control instant
        L = np.zeros((0, n, 0))
        eff_full = []
        for args, pi in zip(eff_args, eff_pi):
            eff_full += args + [np.zeros((len(args[3]), int(args[2].max()) + 1 if args[2].size else 0), np.int64), pi]
        layout.lc_act = np.zeros((0, nc), np.int64)
        layout.lc_y = layout.lc_ctrl = np.zeros(0, np.int64)
        tabs.update(lc_act=layout.lc_act, act_j=act_j[:0], lc_y=layout.lc_y, y_j=layout.lc_y, lc_ctrl=layout.lc_ctrl,
                    ctrl_j=ctrl_j[:0])

    # plant arrays ------------------------------------------------------------------------------------
    dummy = np.zeros((n, nc), dtype=np.int64)
    tire_t = _i64(P.tire_t) if P.has_tire else dummy
    eff_t = _i64(P.eff_t) if P.has_tire else dummy
    kt, ct = _f64(sim.kt), _f64(sim.ct)
    Jb = _f64(sim.Jb)
    cmd, F_act, F_eff, F_teff = (np.zeros((n, nc)) for _ in range(4))
    acc, v_before = np.zeros(m.nv), np.zeros(m.nv)
    sv = np.zeros((n, nc, 2))
    kc_arr = np.zeros(1, np.int64)
    warn = d.warning.number
    warn_idx = np.array([int(w) for w in _BAD_WARNINGS], dtype=np.int64)
    sc0 = sim.scenarios[0].sim
    has_tire_eff = any(e.target == "tire" for e, _ in sim.effects)
    if has_tire_eff and not P.has_tire:  # pragma: no cover - refused when the Simulation is built
        raise RuntimeError("tire effect without a tire")
    # the loop's switches (SPEC_FLAGS): constants of the module, and passed to it as the same values
    flags = (sim.maneuver is not None, bool(P.road_dof), bool(sim.rk4), bool(sim.trap), bool(P.has_tire),
             bool(sim.effects), bool(has_tire_eff))
    has_man, road_dof, rk4, trap, has_tire, has_effects, has_tire_effects = flags
    mod = load_module(effects, actuator, controller, sensor_code, (nc, len(P.body_joints)),
                      (flags, spec_cols, spec_sens))
    fixed = (m._address, d._address, d.qpos, d.qvel, d.ctrl, d.ten_length, d.ten_velocity, warn, warn_idx,
             _i64(P.road_q if P.road_dof else dummy), _i64(P.road_v if P.road_dof else dummy),
             _i64(P.road_servo if P.road_dof else dummy), _i64(P.susp_t), tire_t, _i64(P.eff_s), eff_t,
             _i64(P.act), _i64(P.wheel_q), _i64(P.wheel_v), _i64(P.body_q), _i64(P.body_v),
             _i64(P.free_q), _i64(P.free_v), has_tire, has_effects, has_tire_effects, kt, ct, Jb,
             road_dof, m.tendon_lengthspring, _f64(P.tire_rest0 if not P.road_dof else np.zeros((n, nc, 2))),
             _f64(P.tire_ct if not P.road_dof else np.zeros((n, nc))),
             rk4, d.qfrc_applied, d.qacc, float(P.road_mass),
             trap, _f64(0.5 * P.susp_c), _f64(0.5 * P.tire_c), sim.v_prev, has_man,
             *_maneuver_joints(sim), sim.acc_dofs, sim.v_ctrl, sim.acc_mean, float(sim.acc_period))

    def call(road_z, road_zd, road_zdd, k_chunk0, k, k1, resume):
        if not mod.loop.overloads:  # the first call in this process compiles the loop or loads it from the cache
            with compile_lock(Path(mod.__file__).parent, mod.__name__):  # one process compiles it, the others wait and load it
                return run_chunk(road_z, road_zd, road_zdd, k_chunk0, k, k1, resume)
        return run_chunk(road_z, road_zd, road_zdd, k_chunk0, k, k1, resume)

    def run_chunk(road_z, road_zd, road_zdd, k_chunk0, k, k1, resume):
        return mod.loop(*fixed, road_z, road_zd, road_zdd, man_p, man_r, k_chunk0, k, k1, resume, bool(sim.variations), full, sim.n_steps, sim.sub,
                        sim.log_every, sim.dt, float(sc0.max_displacement), float(sc0.max_velocity),
                        cmd, F_act, F_eff, F_teff, acc, v_before, sv, a_p, a_pi, a_st,
                        sens["field"], sens_cols, sens["aux"], sens["off"], sens["k"], sens["delay"],
                        sens["hold"], sens["bias"], sens["std"], sens["q"], noise, sens["noise_off"], ring, sens_tmp, y,
                        kc_arr, c_p, c_pi, c_st, L, logger.base, layout.LC, tabs["lc_act"], tabs["act_j"], tabs["lc_y"],
                        tabs["y_j"], tabs["lc_ctrl"], tabs["ctrl_j"], *eff_full)

    logger.t[:] = (np.arange(logger.base, logger.base + cap) * sim.log_every) * sim.dt

    def attach_log():
        logger.ch = {name: L[:, :, j].T for j, name in enumerate(layout.names) if name != "__scratch__"}

    if full:
        attach_log()
    chunk = max(sim.sub, 2000 // sim.sub * sim.sub)
    wall0 = _time.perf_counter()
    hooks = list(sim.log_hooks)
    hooked = [0]  # the next log row whose hooks have not run

    def run_hooks(upto):  # the hooks of log rows < upto (buffer rows j - base)
        if hooks:
            for j in range(hooked[0], min(upto, n_log)):
                for hook in hooks:
                    hook(logger, j - logger.base, j * sim.log_every * sim.dt)
        hooked[0] = max(hooked[0], upto)

    for k_chunk0 in range(0, sim.n_steps, chunk):
        k1r = min(k_chunk0 + chunk, sim.n_steps)
        # step-major (step, car, corner): one step's road for all cars is contiguous
        chunks = [np.ascontiguousarray(a.transpose(1, 0, 2), dtype=np.float64) for a in sim.road_chunk(k_chunk0, k1r)]
        # writable, always: a read-only chunk (diagnose's one-car road is a broadcast view) is another argument type
        # to numba, which compiled the whole loop a second time for it (1-3 min under load)
        chunks = [c if c.flags.writeable else c.copy() for c in chunks]
        road_z, road_zd = chunks[0], chunks[1]
        road_zdd = chunks[2] if sim.rk4 else road_z  # RK4: the plates' acceleration (unused otherwise)
        if sim.maneuver is not None:  # the manoeuvre's pitch/roll loads of the chunk's steps
            man_p, man_r = (np.ascontiguousarray(a) for a in sim.maneuver.loads(np.arange(k_chunk0, k1r) * sim.dt))
        else:
            man_p = man_r = np.zeros((1, n))
        k, resume = k_chunk0, 0
        while True:
            k1 = min(k1r, (logger.base + cap) * sim.log_every)  # not past the end of the log buffer
            r = call(road_z, road_zd, road_zdd, k_chunk0, k, k1, resume)
            if r == k1:
                if k1 == k1r:
                    break
                run_hooks(-(-k1 // sim.log_every))  # the buffer is full: hand it on, go on at step k1
                logger.flush()
                k, resume = k1, 0
                continue
            if r >= PRE:  # time-varying parameters at control instant k, as loop.steps applies them
                k, resume = r - PRE, 2
                sim.apply_variations(k * sim.dt)
                continue
            if r < 0:
                kd = -r - 1
                sim.last_forces = (F_act, F_eff, F_teff)
                check_divergence(sim, kd * sim.dt, d)  # raises with the state and a hint
                raise SimulationDiverged(kd * sim.dt, {}, "the compiled loop's state check failed")
            # hybrid: a control instant handled in Python, exactly as loop.steps does
            k, resume = r, 1
            t = k * sim.dt
            jr = k - k_chunk0
            sim.last_forces = (F_act.copy(), F_eff.copy(), F_teff.copy())
            state = plant_state(sim, t, road_z[jr].copy(), road_zd[jr].copy(), acc, F_act.copy(), F_teff.copy(),
                                sim.acc_mean)
            states = {nm: a_st[:, :, a_idx[nm]].copy() for nm in act_names}
            states["force"] = F_act.copy()
            state.actuator_states = states
            command, readings = yield from exchange(sim, t, state)
            cmd[:] = command
            sig = {nm: np.asarray(v, dtype=float).reshape(n, -1) for nm, v in ctrl.signals().items()}
            rd = [(nm, np.asarray(v).reshape(n, -1)) for nm, v in readings.items() if not nm.startswith("state.")]
            if L.shape[2] == 0:  # first control instant: now the log layout is known
                reading_widths[:] = [(nm, v.shape[1]) for nm, v in rd]
                ctrl_widths[:] = [(nm, v.shape[1]) for nm, v in sig.items()]
                y = np.zeros((n, max(1, sum(w for _, w in reading_widths))))
                c_st = np.zeros((n, max(1, sum(w for _, w in ctrl_widths))))
                ctrl_j = np.arange(sum(w for _, w in ctrl_widths), dtype=np.int64)
                L, eff_full = make_log()
                attach_log()
            q = 0
            for _, v in rd:
                y[:, q:q + v.shape[1]] = v
                q += v.shape[1]
            q = 0
            for nm, w in ctrl_widths:
                if nm in sig and sig[nm].shape[1] == w:
                    c_st[:, q:q + w] = sig[nm]
                else:
                    c_st[:, q:q + w] = np.nan
                q += w
        run_hooks(-(-k1r // sim.log_every))
        if progress is not None:
            progress(k1r / sim.n_steps)
    if full:
        ctrl.kernel_sync(c_st)
    sim.end_forces = (acc, F_act, F_teff)
    check_divergence(sim, sim.n_steps * sim.dt, d)
    P.restore_road()
    wall = _time.perf_counter() - wall0
    return wall
