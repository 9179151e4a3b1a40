"""The MuJoCo plant: one MjModel holding an *ensemble* of independent cars (a single run is an ensemble of
one), with index maps that turn MuJoCo's flat arrays into ``(n_cars, n_corners)`` views.

Each car is its vehicle's MJCF (parameters applied, equilibrium preloads set) attached with
``dm_control.mjcf`` under the namespace ``car{i}/`` and offset sideways, so the cars never interact (no
contacts; every force element is a tendon within one car).
"""
from __future__ import annotations

import contextlib
import warnings
from dataclasses import dataclass

import mujoco
import numpy as np
from dm_control import mjcf

from .components import validate_many
from .errors import ScenarioError
from .registry import VEHICLES
from .vehicles.base import levelled_params


@contextlib.contextmanager
def _quiet():
    """Silence MuJoCo's attach warning about an empty prefix (Python warning and absl log line)."""
    from absl import logging as absl_logging

    level = absl_logging.get_verbosity()
    absl_logging.set_verbosity(absl_logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Attaching a spec with an empty prefix")
            yield
    finally:
        absl_logging.set_verbosity(level)


def _idx(m, kind, name):
    i = mujoco.mj_name2id(m, kind, name)
    if i < 0:
        raise KeyError(name)
    return i


@dataclass
class CarGeometry:
    corner_names: list[str]
    suffixes: list[str]
    corner_x: list[float]
    corner_y: list[float]
    tracks: list[int]
    wheelbase: float


class Plant:
    def __init__(self, vehicle_cfgs, dt: float, source: str | None = None, spacing: float = 2.5,
                 integrator: str = "implicitfast"):
        models = {v.model for v in vehicle_cfgs}
        if len(models) != 1:
            raise ScenarioError("an ensemble must use one vehicle model", source=source, field="vehicle.model")
        self.vcls = VEHICLES.get(vehicle_cfgs[0].model, field="vehicle.model", source=source)
        self.params = validate_many(self.vcls.Params, [v.params for v in vehicle_cfgs], "vehicle.params", source)
        # the parameters each car was levelled with when they are not its own (vehicle.levelled_with), else None
        self.level = []
        for v, p in zip(vehicle_cfgs, self.params):
            lv = levelled_params(self.vcls, v.params, v.levelled_with, source) if getattr(v, "levelled_with", None) \
                else None
            self.level.append(None if lv is None or lv == p else lv)
        corners = self.vcls.corners(self.params[0])
        for p in self.params[1:]:
            if len(self.vcls.corners(p)) != len(corners):
                raise ScenarioError("an ensemble's cars must have the same corners", source=source)
        self.n = len(vehicle_cfgs)
        self.corners = corners
        self.nc = len(corners)
        self.dt = dt
        self.body_joints = self.vcls.body_joints
        self.has_tire = all(c.has_tire for c in corners)

        self.spacing = spacing
        self.integrator = integrator
        # The road under a tire enters as the tire spring's rest length (written each step) and a road-rate
        # damper force, not as a moving plate dof: one dof less per corner (MuJoCo steps ~1.5x faster).  RK4
        # keeps the plates (a rest length is held over a step, the plates follow the road within it), and so
        # do models without a tire (the SDOF rig's base carries the suspension itself).
        self.road_dof = integrator == "RK4" or not self.has_tire
        self.model = self._assemble()
        self.data = mujoco.MjData(self.model)
        self._index()

    def use_trapezoidal(self):
        """Switch an implicitfast plant with tires to the trapezoidal scheme: MuJoCo integrates half of each
        linear damper implicitly (the loop applies the other half explicitly).  Used by ``integrator: auto``,
        which decides after the model is built (the scheme's stability limit needs the model's masses)."""
        m = self.model
        self.integrator = "trapezoidal"
        m.tendon_damping[self.susp_t] = 0.5 * self.susp_c
        if self.has_tire:
            m.tendon_damping[self.tire_t] = 0.5 * self.tire_c

    def _assemble(self) -> mujoco.MjModel:
        """The ensemble model: each car's MJCF (built once per distinct parameter set with dm_control, then
        reused as MJCF text) attached with ``mujoco.MjSpec`` under the prefix ``car{i}/``.  Building each car
        as a dm_control tree and attaching those costs ~15 ms per car; cars that share parameters (Monte
        Carlo over roads, seeds, controller gains) now cost ~1 ms.  The compiled dynamics are the same."""
        dt = self.dt
        spec = mujoco.MjSpec()
        spec.modelname = f"{self.vcls.name}_ensemble" if self.n > 1 else self.vcls.name
        spec.compiler.degree = False
        spec.option.timestep = dt
        spec.option.integrator = (mujoco.mjtIntegrator.mjINT_RK4 if self.integrator == "RK4"
                                  else mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
        spec.option.gravity = [0, 0, -9.81]
        spec.visual.global_.offwidth = 1280
        spec.visual.global_.offheight = 720
        cache: dict[str, tuple] = {}
        self._car_xml = []
        group, sub = 16, None  # attach cost grows with the parent's size: cars go in groups of 16 first
        for i, (p, lv) in enumerate(zip(self.params, self.level)):
            key = p.model_dump_json() + ("" if lv is None else lv.model_dump_json())
            if key not in cache:
                root = self.vcls.build(p, dt=dt, level=lv)
                if not self.road_dof:
                    _road_as_rest_length(root, [c.suffix for c in self.corners])
                cache[key] = (root.to_xml_string(), root.get_assets())
            xml, assets = cache[key]
            self._car_xml.append(cache[key])
            child = mujoco.MjSpec.from_string(xml, assets=assets)
            child.modelname = f"car{i}"
            child.option.integrator = spec.option.integrator
            if self.n <= group:
                frame = spec.worldbody.add_frame(pos=[0.0, self.spacing * i, 0.0])
                spec.attach(child, prefix=f"car{i}/", frame=frame)
                continue
            if i % group == 0:
                sub = mujoco.MjSpec()
                sub.modelname = f"cars{i}"
                sub.compiler.degree = False
                sub.option.timestep, sub.option.integrator = dt, spec.option.integrator
                sub.option.gravity = [0, 0, -9.81]
            frame = sub.worldbody.add_frame(pos=[0.0, self.spacing * i, 0.0])
            sub.attach(child, prefix=f"car{i}/", frame=frame)
            if i % group == group - 1 or i == self.n - 1:
                with _quiet():  # names are already unique (car{i}/); MuJoCo warns about the empty prefix
                    spec.attach(sub, prefix="", frame=spec.worldbody.add_frame())
        self.spec = spec
        with _quiet():
            m = spec.compile()
        _skip_unused_stages(m)
        return m

    @property
    def car_roots(self) -> list:
        """Each car's MJCF as a dm_control tree (built on demand)."""
        return [mjcf.from_xml_string(xml, assets=assets) for xml, assets in self._car_xml]

    @property
    def mjcf_root(self):
        """The ensemble as a dm_control MJCF tree (built on demand; the simulated model is :attr:`model`)."""
        world = mjcf.RootElement(model=f"{self.vcls.name}_ensemble" if self.n > 1 else self.vcls.name)
        world.compiler.angle = "radian"
        world.option.timestep = self.dt
        world.option.integrator = "implicitfast"
        world.option.gravity = [0, 0, -9.81]
        for i, r in enumerate(self.car_roots):
            r.model = f"car{i}"
            frame = world.worldbody.attach(r)
            frame.pos = [0.0, self.spacing * i, 0.0]
        return world

    # ------------------------------------------------------------------------------------------------
    def _index(self):
        m = self.model
        J, T, A = mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_TENDON, mujoco.mjtObj.mjOBJ_ACTUATOR
        n, nc = self.n, self.nc
        sfx = [c.suffix for c in self.corners]
        self.suffixes = sfx

        def grid(kind, fmt, fn):
            out = np.zeros((n, nc), dtype=np.int64)
            for i in range(n):
                for c, s in enumerate(sfx):
                    out[i, c] = fn(_idx(m, kind, f"car{i}/{fmt.format(s=s)}"))
            return out

        if self.road_dof:
            self.road_q = grid(J, "road_z{s}", lambda j: m.jnt_qposadr[j])
            self.road_v = grid(J, "road_z{s}", lambda j: m.jnt_dofadr[j])
            self.road_servo = grid(A, "road{s}", lambda j: j)
        else:
            self.road_q = self.road_v = self.road_servo = None
        if self.has_tire:
            self.wheel_q = grid(J, "wheel_z{s}", lambda j: m.jnt_qposadr[j])
            self.wheel_v = grid(J, "wheel_z{s}", lambda j: m.jnt_dofadr[j])
            self.tire_t = grid(T, "tire{s}", lambda j: j)
            self.eff_t = grid(A, "effect_tire{s}", lambda j: j)
        else:
            self.wheel_q, self.wheel_v = self.road_q, self.road_v
            self.tire_t = self.eff_t = None
        self.susp_t = grid(T, "suspension{s}", lambda j: j)
        self.act = grid(A, "actuator{s}", lambda j: j)
        self.eff_s = grid(A, "effect_suspension{s}", lambda j: j)
        nb = len(self.body_joints)
        self.body_q = np.zeros((n, nb), dtype=np.int64)
        self.body_v = np.zeros((n, nb), dtype=np.int64)
        for i in range(n):
            for k, jn in enumerate(self.body_joints):
                j = _idx(m, J, f"car{i}/{jn}")
                self.body_q[i, k] = m.jnt_qposadr[j]
                self.body_v[i, k] = m.jnt_dofadr[j]
        # static preloads (spring force carried at equilibrium)
        self.static_susp = m.tendon_stiffness[self.susp_t] * m.tendon_lengthspring[self.susp_t, 0]
        if self.has_tire:
            self.static_tire = m.tendon_stiffness[self.tire_t] * m.tendon_lengthspring[self.tire_t, 0]
        else:
            self.static_tire = self.static_susp.copy()
        # the linear dampers' full coefficients (the trapezoidal scheme leaves half of them to MuJoCo)
        self.susp_c = m.tendon_damping[self.susp_t].copy()
        self.tire_c = m.tendon_damping[self.tire_t].copy() if self.has_tire else np.zeros_like(self.susp_c)
        if not self.road_dof:  # the tire springs' rest lengths at equilibrium (road at 0)
            self.tire_rest0 = m.tendon_lengthspring[self.tire_t].copy()  # (n, nc, 2)
            self.tire_ct = self.tire_c.copy()
        if self.integrator == "trapezoidal":
            self.use_trapezoidal()
        self.road_mass = 1e12
        if self.integrator == "RK4":
            # RK4 evaluates forces at intermediate stages: keep the road plates on their kinematic path
            # within a step (the loop sets their position and velocity at each step start) by making them
            # so heavy that the tire reaction cannot move them, and switch off their standalone servos.
            for i in range(n):
                for c, s in enumerate(sfx):
                    m.body_mass[m.jnt_bodyid[_idx(m, J, f"car{i}/road_z{s}")]] = self.road_mass
            m.actuator_gainprm[self.road_servo.ravel(), :] = 0.0
            m.actuator_biasprm[self.road_servo.ravel(), :] = 0.0
            mujoco.mj_setConst(m, mujoco.MjData(m))
        road_q = self.road_q.ravel() if self.road_dof else []
        road_v = self.road_v.ravel() if self.road_dof else []
        self.free_q = np.setdiff1d(np.arange(m.nq), road_q)
        self.free_v = np.setdiff1d(np.arange(m.nv), road_v)

    def place_road(self, d, road: np.ndarray, road_vel: np.ndarray) -> None:
        """Put the road height and rate (n_cars, n_corners) under the wheels for the coming step: the plates'
        position, velocity and servo target, or the tire springs' rest lengths (the road-rate part of the tire
        damper is added to the tire effect force by :meth:`tire_road_force`)."""
        if self.road_dof:
            d.qpos[self.road_q] = road
            d.qvel[self.road_v] = road_vel
            d.ctrl[self.road_servo] = road
        else:
            ls = self.model.tendon_lengthspring
            ls[self.tire_t, 0] = self.tire_rest0[:, :, 0] + road
            ls[self.tire_t, 1] = self.tire_rest0[:, :, 1] + road

    def tire_road_force(self, road_vel: np.ndarray):
        """Force the road rate applies through the tire damper (c_t·ż_r), or 0 with road plates."""
        return 0.0 if self.road_dof else self.tire_ct * road_vel

    def tire_deflection(self, d, road: np.ndarray, road_vel: np.ndarray):
        """(wheel − road, its rate) from equilibrium, (n_cars, n_corners): the tire tendon's length and rate."""
        tl, tr = d.ten_length[self.tire_t], d.ten_velocity[self.tire_t]
        if self.road_dof:
            return tl, tr
        return tl - road, tr - road_vel

    def restore_road(self) -> None:
        """Put the tire springs' rest lengths back to equilibrium (after a run)."""
        if not self.road_dof:
            self.model.tendon_lengthspring[self.tire_t] = self.tire_rest0

    # ------------------------------------------------------------------------------------------------
    @property
    def geometry(self) -> CarGeometry:
        return CarGeometry(
            corner_names=[c.name for c in self.corners], suffixes=self.suffixes,
            corner_x=[c.x for c in self.corners], corner_y=[c.y for c in self.corners],
            tracks=[c.track for c in self.corners], wheelbase=self.vcls.wheelbase(self.params[0]))

    def tendon_values(self, field: str, which: str = "suspension") -> np.ndarray:
        idx = self.susp_t if which == "suspension" else self.tire_t
        return getattr(self.model, field)[idx].copy()

    def variation_index(self, param: str, corners: list[str] | None = None):
        """(MjModel field name, flat index array (n_cars, k)) changed by a vehicle parameter (on ``corners``
        only, when given: the parameter's elements named ``*_<corner>``)."""
        from .vehicles.base import targets_on_corners

        m = self.model
        targets = self.vcls.variation_targets(self.params[0])
        if param not in targets:
            raise ScenarioError(f"parameter {param!r} cannot vary in time for model {self.vcls.name!r} "
                                f"(can: {', '.join(targets)})", field="vehicle.variations.param")
        chosen = targets[param]
        if corners is not None:
            chosen = targets_on_corners(chosen, list(corners), list(self.vcls.corner_names(self.params[0])))
            if chosen is None:
                raise ScenarioError(f"parameter {param!r} does not act on corner(s) {list(corners)}",
                                    field="vehicle.variations.corners")
        fields = set()
        cols = []
        for kind, elem, k in chosen:
            objtype = mujoco.mjtObj.mjOBJ_BODY if kind.startswith("body") else mujoco.mjtObj.mjOBJ_TENDON
            ids = [_idx(m, objtype, f"car{i}/{elem}") for i in range(self.n)]
            fields.add(kind)
            if kind == "body_inertia":
                cols.append([3 * j + k for j in ids])
            else:
                cols.append(ids)
        if len(fields) != 1:
            raise RuntimeError("a parameter must map onto one MjModel field")
        return fields.pop(), np.asarray(cols, dtype=np.int64).T


def _road_as_rest_length(root, suffixes) -> None:
    """Remove the road plates' slide joints and servos from a car's MJCF tree (dm_control): each tire tendon
    is then the wheel alone, and the plates stay as static geometry (see Plant.road_dof)."""
    for s in suffixes:
        name = f"road_z{s}"
        tendon = root.find("tendon", f"tire{s}")
        for w in list(tendon.joint):
            ref = w.joint.name if hasattr(w.joint, "name") else w.joint
            if ref == name:
                w.remove()
        servo = root.find("actuator", f"road{s}")
        if servo is not None:
            servo.remove()
        root.find("joint", name).remove()


def _skip_unused_stages(m: mujoco.MjModel) -> None:
    """Switch off MuJoCo's contact and constraint stages when the model has nothing for them (no contact-
    capable geoms, equality constraints, limits or friction loss; the built-in models): they cost ~10 % of
    a step doing nothing, and the results are the same bit for bit."""
    if (m.neq == 0 and not np.any(m.geom_contype | m.geom_conaffinity) and not np.any(m.jnt_limited)
            and not np.any(m.tendon_limited) and not np.any(m.dof_frictionloss) and not np.any(m.tendon_frictionloss)):
        m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT) | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
