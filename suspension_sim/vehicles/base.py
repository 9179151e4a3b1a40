"""Vehicle model interface and the MJCF conventions every model follows.

Each model is a plain MJCF file in ``models/`` plus a :class:`Vehicle` subclass that says how scenario
parameters map onto the file.  Naming conventions inside the MJCF (``{s}`` is the corner suffix: empty for
one-corner models, ``_front``/``_rear``, ``_fl``/``_fr``/``_rl``/``_rr``):

- joints ``road_z{s}`` (road plate, moved kinematically), ``wheel_z{s}`` (unsprung mass, absent for the
  SDOF rig), and the body joints listed in :attr:`Vehicle.body_joints` (``body_z``, ``pitch``, ``roll``),
  all in world coordinates;
- fixed tendons ``suspension{s}`` (length = body point above the corner − wheel = suspension travel,
  positive = extension) and ``tire{s}`` (length = wheel − road; negative = tire compression);
- motors ``actuator{s}`` and ``effect_suspension{s}`` on the suspension tendon, ``effect_tire{s}`` on the
  tire tendon (positive force pushes the body up and the wheel down), and a ``road{s}`` position servo
  used only when the file is simulated alone.

Positions are measured from the static equilibrium: :func:`equilibrium_preloads` computes the tendon
spring lengths (preloads) that make ``qpos = 0`` the equilibrium under gravity for the given parameters.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from dm_control import mjcf

from ..components import Params

GRAVITY = 9.81


def models_dir() -> Path:
    """Folder of the MJCF files (the repository's ``models/``, installed as ``suspension_sim.mjcf_models``)."""
    env = os.environ.get("SUSPENSION_SIM_MODELS")
    if env:
        return Path(env)
    repo = Path(__file__).resolve().parents[2] / "models"
    if (repo / "quarter_car.xml").exists():
        return repo
    from importlib.resources import files

    return Path(str(files("suspension_sim.mjcf_models")))


@dataclass
class Corner:
    name: str
    suffix: str
    x: float  # longitudinal position of the axle relative to the c.g. (m, forward positive)
    y: float = 0.0  # lateral position (m, left positive)
    track: int = 0  # road track index (0 = left/only, 1 = right)
    has_tire: bool = True


class Vehicle:
    """Base class of a vehicle model. Subclasses set ``xml``, ``Params``, ``body_joints`` and
    implement :meth:`corners` and :meth:`apply_params`."""

    name = "vehicle"
    xml = ""
    Params = Params
    body_joints: tuple[str, ...] = ("body_z",)

    @classmethod
    def corners(cls, p) -> list[Corner]:
        raise NotImplementedError

    @classmethod
    def corner_names(cls, p) -> list[str]:
        return [c.name for c in cls.corners(p)]

    @classmethod
    def apply_params(cls, root: mjcf.RootElement, p) -> None:
        """Write parameter values into the MJCF tree (masses, stiffnesses, geometry)."""
        raise NotImplementedError

    @classmethod
    def wheelbase(cls, p) -> float:
        xs = [c.x for c in cls.corners(p)]
        return max(xs) - min(xs)

    # -- building --------------------------------------------------------------------------------------
    @classmethod
    def build(cls, p, dt: float | None = None, level=None) -> mjcf.RootElement:
        """The model's MJCF with parameters applied and equilibrium preloads set: those of the car with the
        parameters ``level`` (its masses differ from ``p``'s: ``vehicle.levelled_with``) when given, so that the
        springs carry that car's weight at zero travel."""
        root = mjcf.from_path(str(models_dir() / cls.xml))
        cls.apply_params(root, p)
        if dt is not None:
            root.option.timestep = dt
        if level is None:
            set_equilibrium_preloads(root)
            return root
        for t in cls.build(level).find_all("tendon"):
            if t.springlength is not None:
                root.find("tendon", t.name).springlength = t.springlength
        return root

    # parameter names that scale per corner, used by time-varying variations
    @classmethod
    def variation_targets(cls, p) -> dict[str, list[tuple[str, str, int]]]:
        """Map a parameter name to the MjModel fields it changes: a list of (kind, element name, index)
        where kind is 'body_mass', 'body_inertia', 'tendon_stiffness' or 'tendon_damping'."""
        return {}


def mass_params(vcls, p=None) -> list[str]:
    """The vehicle parameters that are masses or inertias (what the springs carry; their variation targets are
    bodies): the parameters a car can be levelled with (``vehicle.levelled_with``)."""
    p = vcls.Params() if p is None else p
    return [n for n, t in vcls.variation_targets(p).items() if t and all(k.startswith("body") for k, _, _ in t)]


def levelled_params(vcls, params: dict, level, source: str | None = None, field: str = "vehicle.levelled_with",
                    model: str | None = None, params_field: str = "vehicle.params"):
    """The parameters of the car the springs were levelled with (``vehicle.levelled_with`` of a scenario, or
    ``levelled_with`` of a fitted model file): the car's own ``params`` (errors named ``params_field``) with the
    masses and inertias ``level`` in place of its own, validated as the vehicle's parameters.  The one check of
    both inputs: ``level`` must be a mapping of the model's masses and inertias (:func:`mass_params`) whose values
    the vehicle's parameters accept (positive, finite, no lax conversions); anything else is a one-line
    ScenarioError naming ``field``.  ``vcls`` None: a model without masses (diagnose's damper element)."""
    from ..components import validate_params
    from ..errors import ScenarioError

    model = model or getattr(vcls, "name", "the model")
    if not isinstance(level, dict):
        raise ScenarioError(f"expects a mapping of masses and inertias, got {type(level).__name__} {level!r}"[:300],
                            source=source, field=field)
    masses = [] if vcls is None else mass_params(vcls, validate_params(vcls.Params, params, params_field, source))
    bad = [k for k in level if k not in masses]
    if bad:
        raise ScenarioError(f"{bad[0]!r} is not a mass or inertia of {model!r} (levelled_with takes: "
                            f"{', '.join(masses) or 'nothing'})", source=source, field=f"{field}.{bad[0]}")
    return validate_params(vcls.Params, {**params, **level}, field, source)


def targets_on_corners(targets: list, corners: list[str], all_corners: list[str]) -> list | None:
    """The variation targets of one parameter that act on ``corners`` (MJCF elements named ``*_<corner>``).
    All of them when ``corners`` is every corner of the model; None when the parameter is not per corner
    (no target names a corner) or names none of the chosen ones."""
    if sorted(corners) == sorted(all_corners):
        return list(targets)
    picked = [t for t in targets if any(t[1].endswith(f"_{c}") for c in corners)]
    return picked or None


def set_body_mass(root: mjcf.RootElement, body: str, mass: float) -> None:
    b = root.find("body", body)
    b.inertial.mass = float(mass)


def size_body_box(root: mjcf.RootElement, a: float, b: float, half_width: float | None = None) -> None:
    """Drawing only: stretch the ``body_box`` geom over both axles (a ahead of, b behind the c.g.) and put
    the ``body_nose`` marker at the front."""
    box, nose = root.find("geom", "body_box"), root.find("geom", "body_nose")
    box.size = [0.5 * (a + b) + 0.3, box.size[1] if half_width is None else half_width, box.size[2]]
    box.pos = [0.5 * (a - b), 0.0, 0.0]
    nose.pos = [a + 0.2, nose.pos[1], nose.pos[2]]


def set_tendon(root: mjcf.RootElement, name: str, stiffness: float | None = None, damping: float | None = None):
    t = root.find("tendon", name)
    if stiffness is not None:
        t.stiffness = float(stiffness)
    if damping is not None:
        t.damping = float(damping)


def equilibrium_preloads(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Tendon spring lengths that make qpos = 0 the static equilibrium, and the equilibrium of the
    un-preloaded springs (for information).

    The springs are linear, so with free spring lengths set to zero the equilibrium solves K q = g on the
    free (non-road) degrees of freedom, K = sum_i k_i J_i^T J_i; shifting each spring length to -J_i q_eq
    moves that equilibrium to q = 0 while every spring keeps the force it carries there: with
    L = J q' + J q_eq, the force -k (L - 0) equals -k (L' - L0') for L0' = -J q_eq.
    """
    m = model
    d = mujoco.MjData(m)
    m.tendon_lengthspring[:] = 0.0
    d.qpos[:] = 0
    d.qvel[:] = 0
    mujoco.mj_forward(m, d)
    nv = m.nv
    J = np.zeros((m.ntendon, nv))
    for i in range(m.ntendon):
        # fixed tendons: J row is the constant coefficient vector
        adr, num = m.tendon_adr[i], m.tendon_num[i]
        for j in range(adr, adr + num):
            if m.wrap_type[j] != mujoco.mjtWrap.mjWRAP_JOINT:
                raise ValueError("only fixed tendons are supported for suspension elements")
            jnt = m.wrap_objid[j]
            J[i, m.jnt_dofadr[jnt]] += m.wrap_prm[j]
    road = [m.jnt_dofadr[j] for j in range(m.njnt) if mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j).split("/")[-1].startswith("road_z")]
    free = [i for i in range(nv) if i not in road]
    k = m.tendon_stiffness.copy()
    K = (J.T * k) @ J
    g = -d.qfrc_bias.copy()  # gravity generalized force at rest
    Kf = K[np.ix_(free, free)]
    q = np.zeros(nv)
    q[free] = np.linalg.solve(Kf, g[free])
    lengths = -(J @ q)
    return lengths, q


def set_equilibrium_preloads(root: mjcf.RootElement) -> np.ndarray:
    model = mujoco.MjModel.from_xml_string(root.to_xml_string())
    lengths, _ = equilibrium_preloads(model)
    for i in range(model.ntendon):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TENDON, i)
        root.find("tendon", name).springlength = [float(lengths[i]), float(lengths[i])]
    return lengths
