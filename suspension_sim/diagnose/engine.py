"""The simulator of the discrepancy workflow: the project's own plant, effects and actuator (the MuJoCo model
and the component kernels that ``suspension-sim run`` uses), driven by the measured inputs, run for many
parameter sets at once as an *ensemble of perturbed cars* in one compiled-loop run.

Why this and not a private simulator: one law, one place.  An effect's force law lives in its own file
(``suspension_sim/effects/*.py``) and nowhere else; an effect that declares its free parameters
(``free_parameters``, see :mod:`suspension_sim.free_parameters`) is a diagnose candidate with no edit here.

How a parameter set is simulated:

- the ensemble's MjModel is built once per structure (model, effects and their corners, number of cars,
  geometry) and cached; the vehicle parameters that MuJoCo holds as model fields (masses, inertias, spring
  and damper rates: the vehicle's ``variation_targets``) are written per car before each run.  A changed
  spring or tire stiffness keeps the static preload (the car is re-levelled: same ride height); a changed
  mass does *not* move the equilibrium, so a heavier car sags (as a position sensor zeroed at the nominal
  ride height shows it).  Geometry (axle distances, tracks) rebuilds the plant;
- the effects and the actuator are rebuilt per run from each car's parameters (their kernels run inside the
  compiled loop);
- the measured road of each corner is the road under that wheel, and the measured force input reaches the
  actuator as ``gain·u(t − delay) + offset``, both reconstructed between their samples at the physics steps
  as the record's ``hold`` says (linear by default, or band-limited: :func:`.datafile.reconstruct`; the delay
  is continuous, while the ideal actuator's own ``delay`` is whole physics steps and shared by an ensemble);
- the run starts at rest at equilibrium, or (SDOF) at the position and rate ``init.pos``, ``init.vel`` of a
  parameter set (a held-out record's state estimated from its first, unscored samples: ``Problem``).

The damper element (``model: damper``) has no vehicle: its force is the effects' kernels evaluated at the
prescribed displacement and rate.
"""
from __future__ import annotations

import dataclasses
import threading

import numba
import numpy as np
from suspension_sim.controllers.base import Controller

from ..errors import SimulationDiverged
from ..registry import EFFECTS, VEHICLES
from ..statics import gravity, rest_offset, tendon_jacobian
from ..vehicles.base import mass_params

MAX_DT = 5e-4  # physics step bound (s): the record's sample interval is divided into equal steps below this
BIG = 1e6  # output value of a diverged parameter set
K_EPS = 1e-6  # N/m: the stiffness a zero spring is built with (see Engine._scenario)
_BUILD_LOCK = threading.Lock()


# ------------------------------------------------------------------------------------------------------
# the measured force input as a controller (a table per car, one value per physics step and corner)
# ------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _input_kernel(t, y, p, st, u):
    """One control step (= one physics step) of :class:`MeasuredInput` for one car: the next table row."""
    nc = u.shape[0]
    k = int(st[0])
    n = int(p[0])
    if k > n - 1:
        k = n - 1
    for c in range(nc):
        u[c] = p[1 + k * nc + c]
    st[0] = st[0] + 1.0


class MeasuredInput(Controller):
    """The measured force input replayed per car and corner (one table value per physics step)."""

    name = "measured_input"
    kernel = staticmethod(_input_kernel)

    def __init__(self, table, ctx):
        self.table = table  # (n_cars, n_steps, n_corners)
        super().__init__(None, ctx)

    def reset(self):
        super().reset()
        self._k = 0

    def step(self, t, y):
        k = min(self._k, self.table.shape[1] - 1)
        self._k += 1
        return self.table[:, k, :].copy()

    def kernel_data(self):
        n, ns, nc = self.table.shape
        p = np.empty((n, 1 + ns * nc))
        p[:, 0] = ns
        p[:, 1:] = self.table.reshape(n, -1)
        return p, np.zeros((n, 1))


# ------------------------------------------------------------------------------------------------------
def corner_layout(kind: str, vparams: dict | None = None) -> list:
    """The vehicle's corners (name, suffix, x, y) for the parameters given (defaults elsewhere)."""
    vcls = VEHICLES.get(kind)
    p = vcls.Params(**(vparams or {}))
    return vcls.corners(p)


def output_names(kind: str) -> list[str]:
    """Output channels a record of this model kind may hold (the vocabulary of :mod:`.io`)."""
    if kind == "damper":
        return ["force"]
    if kind == "sdof":
        return ["acc", "vel", "pos"]
    vcls = VEHICLES.get(kind)
    out = []
    for c in corner_layout(kind):
        out += [f"{n}{c.suffix}" for n in ("body_acc", "wheel_acc", "susp_travel", "body_pos", "wheel_pos",
                                           "tire_force")]
    for j in vcls.body_joints:
        if j in ("pitch", "roll"):
            out += [j, f"{j}_rate", f"{j}_acc"]
    return out


def input_names(kind: str) -> tuple[list[str], list[str]]:
    """(every input, the required inputs) of a model kind."""
    if kind == "damper":
        return ["disp", "vel"], ["disp"]
    if kind == "sdof":
        return ["force", "base"], []
    sfx = [c.suffix for c in corner_layout(kind)]
    return [f"{n}{s}" for s in sfx for n in ("road", "force")], [f"road{s}" for s in sfx]


def linear_params(kind: str, quantity: str, corners) -> list[str]:
    """The vehicle parameters that are exactly the linear suspension ``quantity`` (``damping`` or
    ``stiffness``) of the corners ``corners`` ("all" or corner names): each writes that field of the suspension
    tendons of those corners and of no other (the quarter car's ``damping``; the half and full car's
    ``damping_front`` for the front corners).  The damper element's own ``damping`` / ``spring_stiffness``."""
    if kind == "damper":
        return [{"damping": "damping", "stiffness": "spring_stiffness"}[quantity]] if corners == "all" else []
    vcls = VEHICLES.get(kind)
    layout = corner_layout(kind)
    want = {f"suspension{c.suffix}" for c in layout if corners == "all" or c.name in corners}
    out = []
    for name, targets in vcls.variation_targets(vcls.Params()).items():
        if targets and all(t[0] == f"tendon_{quantity}" for t in targets) and {t[1] for t in targets} == want:
            out.append(name)
    return out


def writable_params(kind: str) -> set[str]:
    """Vehicle parameters written into the built MjModel per car (no rebuild)."""
    if kind == "damper":
        return {"spring_stiffness", "damping"}
    vcls = VEHICLES.get(kind)
    return set(vcls.variation_targets(vcls.Params()))


class Engine:
    """Simulate parameter sets of one model structure on a record's inputs.

    ``effects``: list of (label, type, corners, fixed params) (corners "all" or a list of corner names);
    ``vehicle_base``: the vehicle parameters the plant is built with (writable ones are overwritten per
    car).  :meth:`run` takes a list of parameter dicts (names: vehicle parameters, ``<label>.<param>``,
    ``actuator.time_constant``, ``input.gain``, ``input.offset``, ``input.delay``) and returns
    (n_sets, n_samples, n_channels) in the order of :attr:`channels`.  ``level``: the parameters whose masses
    and inertias the car is levelled with (its ride height, where the position sensors read zero; default
    ``vehicle_base``): a set whose masses differ sags from there."""

    def __init__(self, kind: str, inputs: dict, dt_rec: float, effects: list, vehicle_base: dict,
                 lag: bool = False, max_dt: float = MAX_DT, hold: str = "linear", level: dict | None = None):
        self.kind = kind
        self.inputs = inputs
        self.dt_rec = float(dt_rec)
        self.effects = [tuple(e) for e in effects]
        # the loop holds every declared effect (one compiled loop for every candidate: an effect that is not
        # in a parameter set's model runs with its size parameters at zero), plus the model's other effects
        self.slots = _slots(kind, self.effects)
        self.vehicle_base = dict(vehicle_base)
        self.level = dict(vehicle_base if level is None else level)
        self.lag = lag
        self.hold = hold  # the inputs between their samples (datafile.reconstruct)
        self._held: dict = {}
        # runs may come from several threads at once (select fits candidates in parallel): each thread has its
        # own built simulations and its own per-run state (_entries, _sag)
        self._tl = threading.local()
        self.sub = max(1, int(np.ceil(self.dt_rec / max_dt - 1e-9)))
        self.dt = self.dt_rec / self.sub
        self.channels = output_names(kind)
        self.N = len(next(iter(inputs.values())))
        # second order where the project's trapezoidal scheme applies (models with tires), else implicitfast
        self.integrator = "implicitfast"
        if kind != "damper":
            self.vcls = VEHICLES.get(kind)
            self.writable = writable_params(kind)
            self.corners = corner_layout(kind, {k: v for k, v in vehicle_base.items() if k in self.vcls.Params.model_fields})
            self.nc = len(self.corners)
            sfx = [c.suffix for c in self.corners]
            if kind == "sdof":
                road = [inputs.get("base")]
                force = [inputs.get("force")]
            else:
                road = [inputs.get(f"road{s}") for s in sfx]
                force = [inputs.get(f"force{s}") for s in sfx]
            z = np.zeros(self.N)
            self.road = np.stack([z if r is None else np.asarray(r, float) for r in road], axis=1)  # (N, nc)
            self.force = np.stack([z if f is None else np.asarray(f, float) for f in force], axis=1)
            self.has_force = any(f is not None and np.any(f) for f in force)
            if all(c.has_tire for c in self.corners):
                self.integrator = "trapezoidal"

    @property
    def _sims(self) -> dict:
        """This thread's built simulations by (number of sets, samples, geometry)."""
        d = getattr(self._tl, "sims", None)
        if d is None:
            d = self._tl.sims = {}
        return d

    @property
    def _entries(self):
        return getattr(self._tl, "entries", None)

    @_entries.setter
    def _entries(self, value):
        self._tl.entries = value

    @property
    def _sag(self):
        return getattr(self._tl, "sag", None)

    @_sag.setter
    def _sag(self, value):
        self._tl.sag = value

    # --------------------------------------------------------------------------------------------------
    def _scenario(self, vparams: dict, n_samples: int):
        from ..config import parse_scenario

        eff = [{"type": t, "corners": c, "params": dict(fixed)} for t, c, fixed in self.slots]
        # a zero spring has no static equilibrium under gravity (the MJCF cannot be built): a vanishing one
        # (K_EPS) carries the static load through its preload instead, with no force of its own to speak of
        vparams = {k: (K_EPS if "stiffness" in k and v == 0 else v) for k, v in vparams.items()}
        # effect parameters that need values to validate: the fixed ones plus defaults (overwritten per run)
        return parse_scenario({
            "name": "diagnose", "vehicle": {"model": self.kind, "params": vparams, "effects": eff},
            "road": {"type": "flat"}, "actuator": {"type": "ideal", "params": {}},
            "controller": {"type": "passive"},
            "sim": {"duration": n_samples * self.dt_rec, "dt": self.dt, "control_dt": self.dt,
                    "integrator": self.integrator,
                    "log_dt": self.dt_rec, "max_displacement": 1e3, "max_velocity": 1e4},
            "outputs": {"timeseries": True, "plots": False}})

    def _sim(self, psets: list[dict], n_samples: int):
        from ..simulation import Simulation

        geo = []
        for P in psets:
            geo.append(tuple(sorted((k, float(v)) for k, v in P.items()
                                    if k in self.vcls.Params.model_fields and k not in self.writable)))
        base = {k: v for k, v in self.vehicle_base.items() if k in self.vcls.Params.model_fields}
        # built (its springs' preloads set) with the masses it is levelled with: a set's own masses are written
        # per run (_write_vehicle), so a set heavier than the level sags, whichever set first built the engine
        base.update({k: self.level[k] for k in mass_params(self.vcls) if k in self.level})
        key = (len(psets), n_samples, tuple(geo))
        sims = self._sims
        hit = sims.get(key)
        if hit is not None:
            return hit
        with _BUILD_LOCK:  # (building a model is not thread-safe)
            if len(sims) > 6:
                sims.clear()
            scs = [self._scenario({**base, **dict(g)}, n_samples) for g in geo]
            sim = Simulation(scs)
        P = sim.plant
        m = P.model
        import mujoco

        sim._diag = {
            "fields": {name: P.variation_index(name) for name in self.writable},
            "base": {f: getattr(m, f).copy() for f in ("body_mass", "body_inertia", "tendon_stiffness",
                                                       "tendon_damping", "tendon_lengthspring")},
            "tire_rest0": None if P.road_dof else P.tire_rest0.copy(),
            "scratch": mujoco.MjData(m),
            "n_samples": n_samples,
        }
        sim._diag["J"], sim._diag["g0"] = tendon_jacobian(m), gravity(m, sim._diag["scratch"])
        sims[key] = sim
        return sim

    def _write_vehicle(self, sim, psets):
        import mujoco

        P, m = sim.plant, sim.plant.model
        D = sim._diag
        for f, arr in D["base"].items():
            getattr(m, f)[...] = arr
        if D.get("const_dirty"):
            # a previous run changed a mass: MuJoCo's constants derived from the masses (dof_M0, the mass matrix
            # of slide-joint bodies, among them) are recomputed for the base masses, or this run would keep that
            # run's inertia with the base weight (a parameter set's result would depend on the sets run before it)
            mujoco.mj_setConst(m, D["scratch"])
            D["const_dirty"] = False
        mass_changed = False
        for name, (fld, idx) in D["fields"].items():
            vals = np.array([float(Pd.get(name, self.vehicle_base.get(name, np.nan))) for Pd in psets])
            if np.any(np.isnan(vals)):
                continue
            flat = getattr(m, fld).reshape(-1) if fld == "body_inertia" else getattr(m, fld)
            old = flat[idx].copy()
            new = np.broadcast_to(vals[:, None], idx.shape)
            if fld == "tendon_stiffness":
                new = np.maximum(new, K_EPS)
                # keep the static preload k·L0 (re-levelled: the same ride height)
                ls = m.tendon_lengthspring
                ratio = np.where(new > 0, old / np.where(new > 0, new, 1.0), 1.0)
                for col in range(idx.shape[1]):
                    ls[idx[:, col], 0] *= ratio[:, col]
                    ls[idx[:, col], 1] *= ratio[:, col]
            if fld.startswith("body") and np.any(new != old):
                mass_changed = True
            if fld == "tendon_damping" and sim.trap:
                new = 0.5 * new  # MuJoCo holds half of each linear damper with the trapezoidal scheme
            flat[idx] = new
        self._sag = None
        D["q0"] = None
        if mass_changed:
            mujoco.mj_setConst(m, D["scratch"])
            D["const_dirty"] = True
            if self.kind != "sdof" and not np.any(m.tendon_stiffness <= 1.5 * K_EPS):
                # a car with real springs sags where its springs (and effects) carry the new weight: the run
                # starts there (_static_state), not re-levelled, so an effect sees the travel from the nominal
                # ride height, where its law is written (a stop's gap, a cubic spring's zero are places on the
                # car; re-levelled, a heavier car's stop moved with the sag: the blind battery's loaded SUV
                # rested on its 36 mm stop after a 38 mm sag and was fitted a 0 mm stop with a freed spring)
                D["q0"] = "static"
                return self._linear_rates(sim)
            # a changed mass is not re-levelled in the world (the car sags), but a run starting at rest at the
            # old ride height would drop at t = 0 and ring: the model is re-levelled (q = 0 is its new
            # equilibrium) and the static sag K⁻¹·Δg is added to the position outputs instead
            J = D["J"]
            dg = gravity(m, D["scratch"]) - D["g0"]
            free = P.free_v
            K = (J.T * m.tendon_stiffness) @ J
            q = np.zeros(m.nv)
            q[free] = np.linalg.solve(K[np.ix_(free, free)], dg[free])
            dl = J @ q
            m.tendon_lengthspring[:, 0] -= dl
            m.tendon_lengthspring[:, 1] -= dl
            # the sag shown at the sensors is the real springs' deflection: a zero spring (K_EPS) carries the
            # static load through its preload, at any mass, like a support (a horizontal stage, a rig on a
            # stop), so it deflects as if rigid.  (Its own Δm·g/K_EPS, 91 km for 9 g on the EMPS stage, froze
            # the mass at its start value and made the fit's covariance degenerate.)
            ks = m.tendon_stiffness.copy()
            eps = ks <= 1.5 * K_EPS
            if eps.any():
                if eps.all():
                    q = np.zeros(m.nv)
                else:
                    ks[eps] = 1e6 * ks[~eps].max()
                    K = (J.T * ks) @ J
                    q = np.zeros(m.nv)
                    q[free] = np.linalg.solve(K[np.ix_(free, free)], dg[free])
                dl = J @ q
            self._sag = {"body": q[P.body_v], "wheel": q[P.wheel_v] if P.has_tire else None,
                         "travel": dl[P.susp_t],
                         "tire": (-m.tendon_stiffness[P.tire_t] * dl[P.tire_t]) if P.has_tire else None}
        self._linear_rates(sim)

    @staticmethod
    def _linear_rates(sim):
        """The plant's and the simulation's copies of the linear rates, from the model's fields."""
        P, m = sim.plant, sim.plant.model
        f = 2.0 if sim.trap else 1.0
        P.susp_c = f * m.tendon_damping[P.susp_t]
        if P.has_tire:
            P.tire_c = f * m.tendon_damping[P.tire_t]
            sim.kt = m.tendon_stiffness[P.tire_t].copy()
            sim.ct = P.tire_c
            if not P.road_dof:
                P.tire_rest0 = m.tendon_lengthspring[P.tire_t].copy()
                P.tire_ct = P.tire_c.copy()
        P.static_susp = m.tendon_stiffness[P.susp_t] * m.tendon_lengthspring[P.susp_t, 0]

    def _components(self, sim, psets):
        from ..components import stack_params, validate_params
        from ..registry import ACTUATORS

        n = len(psets)
        new = []
        entries = getattr(self, "_entries", None) or self.effects
        for (etype, scorners, sfixed), (old, sel) in zip(self.slots, sim.effects):
            ecls = EFFECTS.get(etype)
            names = list(ecls.Params.model_fields)
            decl = getattr(ecls, "free_parameters", None) or {}
            ent = next((e for e in entries if e[1] == etype and (scorners == "all" or e[2] == scorners)), None)
            plist = []
            corner_names = [self.corners[c].name for c in sel]
            for Pd in psets:
                if ent is None:  # not in this model: its size parameters at zero
                    d = dict(sfixed)
                    d.update({pn: 0.0 for pn, fp in decl.items() if fp.size})
                else:
                    label, _t, corners, fixed = ent
                    d = dict(fixed)
                    for pn in names:
                        key = f"{label}.{pn}"
                        if key in Pd:
                            v = float(Pd[key])
                            if corners != "all" and scorners == "all" and decl.get(pn) is not None and decl[pn].size:
                                v = [v if cn in corners else 0.0 for cn in corner_names]
                            d[pn] = v
                plist.append(validate_params(ecls.Params, d, f"effect {etype}"))
            # the effect's context with this run's linear damping of its corners (each set's own, written by
            # _write_vehicle: a law of the car's damper, maxwell_damper, is that set's damper)
            ctx = dataclasses.replace(old.ctx, damping=np.ascontiguousarray(sim.plant.susp_c[:, sel], dtype=float))
            new.append((ecls(stack_params(plist, len(sel)), ctx), sel))
        sim.effects = new
        acls = ACTUATORS.get("ideal")
        ap = [validate_params(acls.Params, {"time_constant": max(float(Pd.get("actuator.time_constant", 0.0)), 0.0)},
                              "actuator") for Pd in psets]
        sim.actuator = acls(stack_params(ap, self.nc), sim.actuator.ctx)
        # force input table per car: gain·u(t − delay) + offset at each physics step.  A record without a force
        # input replays a one-row table of zeros (the table's last row holds): the same zero command as the
        # passive controller, through the same controller kernel, so a road-only and a force record of one
        # model structure run one compiled loop (a loop is compiled per controller kernel: 8-14 s each)
        ns = sim.n_steps
        if self.has_force or any(float(Pd.get("input.offset", 0.0)) != 0.0 for Pd in psets):
            tk = np.arange(ns) * self.dt
            tab = np.empty((n, ns, self.nc))
            for i, Pd in enumerate(psets):
                g = float(Pd.get("input.gain", 1.0))
                o = float(Pd.get("input.offset", 0.0))
                d = float(Pd.get("input.delay", 0.0))
                for c in range(self.nc):
                    tab[i, :, c] = g * self._at("force", c, tk - d) + o
        else:
            tab = np.zeros((n, 1, self.nc))
        sim.controller = MeasuredInput(tab, sim.cctx)

        # road per corner, at the physics steps
        tk = np.arange(ns + 2) * self.dt - self.dt
        zr = np.stack([self._at("road", c, tk) for c in range(self.nc)], axis=1)  # (ns+2, nc)

        def chunk(k0, k1, zr=zr, n=n):
            z = zr[k0 + 1:k1 + 1]
            zd = (zr[k0 + 2:k1 + 2] - zr[k0:k1]) / (2 * self.dt)
            return (np.ascontiguousarray(np.broadcast_to(z[None], (n,) + z.shape)),
                    np.ascontiguousarray(np.broadcast_to(zd[None], (n,) + zd.shape)))

        sim.road_chunk = chunk  # the loops read the road through System.road_chunk

    def _at(self, name: str, c: int, t):
        """Measured input ``name`` ("force" or "road") of corner ``c`` at times ``t`` (its samples are at
        k·dt_rec), reconstructed per :attr:`hold`; cached (the same times recur in every run)."""
        from .datafile import reconstruct

        key = (name, c, t.shape[0], float(t[0]), float(t[-1]))
        hit = self._held.get(key)
        if hit is None:
            if len(self._held) > 16:
                self._held.clear()
            hit = self._held[key] = reconstruct(getattr(self, name)[:, c], self.dt_rec, t, self.hold)
        return hit

    # --------------------------------------------------------------------------------------------------
    def run(self, psets: list[dict], n_samples: int | None = None, effects: list | None = None,
            outputs=None) -> np.ndarray:
        """Outputs (n_sets, n_samples, n_channels); a diverged set gives :data:`BIG` everywhere.  ``effects``:
        the model's effect entries for these sets (default: the engine's own).  ``outputs``: the channels the
        caller reads (default: all); the others are not computed (NaN)."""
        n_samples = self.N if n_samples is None else int(n_samples)
        self._entries = [tuple(e) for e in effects] if effects is not None else None
        if self.kind == "damper":
            return self._run_damper(psets, n_samples)
        try:
            return self._run(psets, n_samples, outputs)
        except SimulationDiverged:
            if len(psets) == 1:
                return np.full((1, n_samples, len(self.channels)), BIG)
            return np.concatenate([self.run([P], n_samples, effects, outputs) for P in psets], axis=0)

    def _sources(self, outputs) -> dict:
        """{output channel: the log channels it is made of} for ``outputs`` (None: every output channel)."""
        want = self.channels if outputs is None else [c for c in self.channels if c in set(outputs)]
        if self.kind == "sdof":
            return {c: [{"acc": "body_acc", "vel": "body_vel", "pos": "body_z"}[c]] for c in want}
        joints = [j for j in self.vcls.body_joints if j in ("pitch", "roll")]
        out = {}
        for c in want:
            for corner in self.corners:
                s = corner.suffix
                if c == f"body_acc{s}":
                    out[c] = ["body_acc"] + [f"{j}_acc" for j in joints]
                elif c == f"body_pos{s}":
                    out[c] = ["body_z"] + joints
                for o, lg in (("wheel_acc", "wheel_acc"), ("susp_travel", "travel"), ("wheel_pos", "wheel_z"),
                              ("tire_force", "tire_force")):
                    if c == f"{o}{s}":
                        out[c] = [f"{lg}{s}"]
            if c in ("pitch", "roll", "pitch_rate", "roll_rate", "pitch_acc", "roll_acc"):
                out[c] = [c]
        return out

    def _log(self, sim, keep) -> dict:
        """Run ``sim``; its log channels {name: (n_sets, log rows)}.  The compiled loop logs only the channels
        in ``keep`` and nothing else is made of its log (a Simulation's run also makes every car's Result and
        its metrics, 5-15 % of a diagnose run's time, and streams a log larger than its buffer through Parquet);
        the Python loop (``SUSPENSION_SIM_COMPILED=0``) runs the whole Simulation."""
        from ..build import n_log_samples
        from ..compiled.loop import plan, run as run_compiled
        from ..log import Logger
        from ..loop import one_blas_thread

        mode, sim.loop_reason = plan(sim)
        sim.loop = mode or "python"
        if mode is None:
            res = sim.run()
            src = res[0].__dict__.get("_src")
            return src[1] if src is not None else {c: np.stack([r.ts[c].to_numpy() for r in res]) for c in res[0].ts}
        sim.log_channels = set(keep)
        logger = Logger(sim, n_log=n_log_samples(sim.n_steps, sim.log_every))  # held whole
        with one_blas_thread():
            run_compiled(sim, mode, None, logger)
        return logger.ch

    def _run(self, psets, n_samples, outputs=None):
        sim = self._sim(psets, n_samples)
        self._write_vehicle(sim, psets)
        self._components(sim, psets)
        self._static_state(sim)
        self._initial_state(sim, psets)
        srcs = self._sources(outputs)
        ch = self._log(sim, {"body_z"} | {lg for v in srcs.values() for lg in v})
        n = len(psets)
        out = np.empty((n, n_samples, len(self.channels))) if outputs is None else \
            np.full((n, n_samples, len(self.channels)), np.nan)
        L = min(n_samples, ch["body_z"].shape[1])

        def g(name):
            a = ch.get(name)
            return np.zeros((n, L)) if a is None else a[:, :L]

        if self.kind == "sdof":
            for j, (c, src_name) in enumerate((("acc", "body_acc"), ("vel", "body_vel"), ("pos", "body_z"))):
                if c in srcs:
                    out[:, :L, j] = g(src_name)
        else:
            idx = {c: j for j, c in enumerate(self.channels)}
            for ci, corner in enumerate(self.corners):
                s = corner.suffix
                if f"body_acc{s}" in srcs or f"body_pos{s}" in srcs:
                    xy = [self._corner_xy(Pd, ci) for Pd in psets]
                    xs = np.array([p[0] for p in xy])[:, None]
                    ys = np.array([p[1] for p in xy])[:, None]
                if f"body_acc{s}" in srcs:
                    out[:, :L, idx[f"body_acc{s}"]] = g("body_acc") - xs * g("pitch_acc") + ys * g("roll_acc")
                if f"body_pos{s}" in srcs:
                    out[:, :L, idx[f"body_pos{s}"]] = g("body_z") - xs * g("pitch") + ys * g("roll")
                for o, lg in (("wheel_acc", "wheel_acc"), ("susp_travel", "travel"), ("wheel_pos", "wheel_z"),
                              ("tire_force", "tire_force")):
                    if f"{o}{s}" in srcs:
                        out[:, :L, idx[f"{o}{s}"]] = g(f"{lg}{s}")
            for j in ("pitch", "roll", "pitch_rate", "roll_rate", "pitch_acc", "roll_acc"):
                if j in idx and j in srcs:
                    out[:, :L, idx[j]] = g(j)
        if self._sag is not None:
            self._add_sag(out, psets)
        if L < n_samples:
            out[:, L:, :] = out[:, L - 1:L, :]
        return out

    def _static_state(self, sim):
        """A car whose mass changed (not re-levelled, :meth:`_write_vehicle`) starts at rest where its springs and
        suspension effects carry the changed weight (:func:`suspension_sim.statics.rest_offset`, the function
        ``suspension-sim run`` starts a car heavier than its ``levelled_with`` at)."""
        D = sim._diag
        if D.get("q0") is None:
            sim.initial_q = None
            return
        m = sim.plant.model
        sim.initial_q = rest_offset(sim.plant, sim.effects, gravity(m, D["scratch"]) - D["g0"], D["J"])

    def _initial_state(self, sim, psets):
        """SDOF: start each car at ``init.pos`` (the position output) and ``init.vel`` instead of at rest."""
        sim.initial_v = None
        if self.kind != "sdof" or not any("init.pos" in Pd or "init.vel" in Pd for Pd in psets):
            return
        x0 = np.array([float(Pd.get("init.pos", 0.0)) for Pd in psets])
        v0 = np.array([float(Pd.get("init.vel", 0.0)) for Pd in psets])
        if self._sag is not None:  # the position output carries the static sag; the joint starts at x0 − sag
            x0 = x0 - self._sag["body"][:, 0]
        m = sim.plant.model
        dof = sim.plant.body_v[:, 0]
        q = np.zeros(m.nv) if sim.initial_q is None else sim.initial_q.copy()
        q[dof] += x0
        v = np.zeros(m.nv)
        v[dof] = v0
        sim.initial_q, sim.initial_v = q, v

    def _add_sag(self, out, psets):
        sg = self._sag
        joints = list(self.vcls.body_joints)
        if self.kind == "sdof":
            out[:, :, self.channels.index("pos")] += sg["body"][:, 0][:, None]
            return
        idx = {c: j for j, c in enumerate(self.channels)}
        zb = sg["body"][:, joints.index("body_z")]
        pb = sg["body"][:, joints.index("pitch")] if "pitch" in joints else 0.0 * zb
        rb = sg["body"][:, joints.index("roll")] if "roll" in joints else 0.0 * zb
        for ci, corner in enumerate(self.corners):
            sfx = corner.suffix
            x = np.array([self._corner_xy(Pd, ci)[0] for Pd in psets])
            y = np.array([self._corner_xy(Pd, ci)[1] for Pd in psets])
            out[:, :, idx[f"body_pos{sfx}"]] += (zb - x * pb + y * rb)[:, None]
            out[:, :, idx[f"susp_travel{sfx}"]] += sg["travel"][:, ci][:, None]
            if sg["wheel"] is not None:
                out[:, :, idx[f"wheel_pos{sfx}"]] += sg["wheel"][:, ci][:, None]
                out[:, :, idx[f"tire_force{sfx}"]] += sg["tire"][:, ci][:, None]
        for j, nm in (("pitch", pb), ("roll", rb)):
            if j in idx:
                out[:, :, idx[j]] += nm[:, None]

    def _corner_xy(self, Pd, ci):
        if not (set(Pd) & (set(self.vcls.Params.model_fields) - self.writable)):
            c = self.corners[ci]
            return c.x, c.y
        vp = {k: v for k, v in {**self.vehicle_base, **Pd}.items() if k in self.vcls.Params.model_fields}
        c = self.vcls.corners(self.vcls.Params(**vp))[ci]
        return c.x, c.y

    # --------------------------------------------------------------------------------------------------
    def _run_damper(self, psets, n_samples):
        """Damper element: measured force = −(−k·s − c·v + Σ effect forces) at the prescribed motion."""
        from ..components import stack_params, validate_params
        from ..effects.base import EffectContext

        n = len(psets)
        s = np.ascontiguousarray(self.inputs["disp"][:n_samples], float)
        v = self.inputs.get("vel")
        v = np.gradient(s, self.dt_rec) if v is None else np.ascontiguousarray(v[:n_samples], float)
        k = np.array([float(Pd.get("spring_stiffness", self.vehicle_base.get("spring_stiffness", 0.0))) for Pd in psets])
        c = np.array([float(Pd.get("damping", self.vehicle_base.get("damping", 0.0))) for Pd in psets])
        F = -k[:, None] * s[None, :] - c[:, None] * v[None, :]
        ones = np.ones((n, 1))
        ctx = EffectContext(n_cars=n, corners=["single"], dt=self.dt_rec, static_suspension_force=0 * ones,
                            static_tire_force=ones, spring_stiffness=k[:, None], damping=c[:, None],
                            tire_stiffness=ones * 1e9, tire_damping=0 * ones, effective_mass=ones * 1e9)
        for label, etype, _corners, fixed in (getattr(self, "_entries", None) or self.effects):
            ecls = EFFECTS.get(etype)
            plist = []
            for Pd in psets:
                d = dict(fixed)
                for pn in ecls.Params.model_fields:
                    if f"{label}.{pn}" in Pd:
                        d[pn] = float(Pd[f"{label}.{pn}"])
                plist.append(validate_params(ecls.Params, d, f"effect {label}"))
            eff = ecls(stack_params(plist, 1), ctx)
            p, st = eff.kernel_data()
            p, st = np.ascontiguousarray(p, float), np.ascontiguousarray(st, float)
            if eff.reads_actuator_force:  # a damper element has no actuator
                _series_fa(type(eff).kernel, s, v, self.dt_rec, p, st, F)
            else:
                _series(type(eff).kernel, s, v, self.dt_rec, p, st, F)
        return (-F)[:, :, None]


@numba.njit(cache=False)
def _series(kernel, s, v, dt, p, st, out):
    """out[i, k] += kernel(s[k], v[k], k·dt, dt, p[i, 0], st[i, 0]) along a prescribed motion, every set i."""
    for k in range(s.shape[0]):
        for i in range(p.shape[0]):
            out[i, k] += kernel(s[k], v[k], k * dt, dt, p[i, 0], st[i, 0])


@numba.njit(cache=False)
def _series_fa(kernel, s, v, dt, p, st, out):
    """As :func:`_series` for a law that reads the actuator force (``Effect.reads_actuator_force``): zero here."""
    for k in range(s.shape[0]):
        for i in range(p.shape[0]):
            out[i, k] += kernel(s[k], v[k], k * dt, dt, p[i, 0], st[i, 0], 0.0)


def levelled_with(kind: str, level: dict, P: dict) -> dict:
    """The masses a scenario replaying parameter set ``P`` states as ``vehicle.levelled_with`` so that
    ``suspension-sim run`` starts the car where the engine does: the ``level`` values of the masses of ``P`` that
    differ from them, on a car with real springs (the engine then does not re-level: :meth:`Engine._write_vehicle`);
    else none (re-levelled, as ``run`` does by itself)."""
    if kind in ("sdof", "damper"):
        return {}
    vcls = VEHICLES.get(kind)
    out = {n: float(level[n]) for n in mass_params(vcls) if n in level and float(P.get(n, level[n])) != float(level[n])}
    if any("stiffness" in k and float(v) <= 1.5 * K_EPS for k, v in P.items() if k in vcls.Params.model_fields):
        return {}
    return out


def effect_candidates() -> dict:
    """Registered effects that declare ``free_parameters`` (each a diagnose candidate)."""
    out = {}
    for name in EFFECTS.names():
        cls = EFFECTS.get(name)
        if getattr(cls, "free_parameters", None) is not None:
            out[name] = cls
    return out


def _slots(kind: str, effects: list) -> list:
    """The effects a compiled loop holds: every declared suspension effect on all corners (settings from its
    ``fit_settings`` or the model's entry of that type), then the model's other effects (tire effects,
    undeclared ones) as given.  Returns [(type, corners, fixed settings)]."""
    if kind == "damper":
        return [(t, c, dict(f)) for _, t, c, f in effects]
    out = []
    decl = effect_candidates()
    for etype, ecls in decl.items():
        if ecls.target != "suspension":
            continue
        mine = [e for e in effects if e[1] == etype]
        fixed = dict(mine[0][3]) if mine else dict(getattr(ecls, "fit_settings", {}) or {})
        out.append((etype, "all", fixed))
    for _, t, c, f in effects:
        if t not in decl or decl[t].target != "suspension":
            out.append((t, c, dict(f)))
    return out


def structure_key(kind: str, effects: list) -> tuple:
    """Parameter sets whose models give equal keys run in one compiled loop."""
    return tuple((t, c if c == "all" else tuple(c), tuple(sorted((k, str(v)) for k, v in f.items())))
                 for t, c, f in _slots(kind, effects))


def effect_force(effects: list, P: dict, s: np.ndarray, v: np.ndarray, dt: float) -> np.ndarray:
    """Sum of the effects' forces (their kernels) along a prescribed travel ``s`` and rate ``v``, for one
    parameter set (``effects``: (label, type, corners, fixed) as for :class:`Engine`)."""
    # the damper element's force is −(−c·v + Σ effects): run with the set's damping (a law of the car's damper,
    # maxwell_damper, reads it) and take the linear c·v back out
    c = float(P.get("damping", 0.0))
    eng = Engine("damper", {"disp": np.asarray(s, float), "vel": np.asarray(v, float)}, dt, effects,
                 {"spring_stiffness": 0.0, "damping": c})
    Pd = {**P, "spring_stiffness": 0.0, "damping": c}
    return -eng.run([Pd])[0, :, 0] + c * np.asarray(v, float)
