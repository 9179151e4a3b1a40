"""Step an ensemble simulation one control step at a time, on the compiled loop.

The compiled loop's *hybrid* mode returns to Python at every control instant, where it samples the declared
sensors and takes the command; :func:`suspension_sim.compiled.loop.run_steps` is that loop as a generator
(yield the readings, receive the command).  :class:`EnsembleRunner` drives it: the physics is exactly that
of ``simulate()`` (roads, effects, actuator, sensor noise and delay, divergence guard), and all the cars of
the ensemble advance in one compiled loop call per control step.  When a component has no kernel the Python
loop's own step-wise interface (:meth:`Simulation.start`/:meth:`Simulation.control_step`) runs instead.
"""
from __future__ import annotations

import mujoco
import numpy as np


class EnsembleRunner:
    """Drive ``sim`` (a built :class:`~suspension_sim.simulation.Simulation`) control step by control step.

    :meth:`start` returns ``(t, readings, state)`` at t = 0; :meth:`step` holds ``command`` (n_cars,
    n_corners) over one control step and returns the next ``(t, readings, state)``, or ``None`` when the run
    has ended.  A diverging run raises :class:`~suspension_sim.errors.SimulationDiverged` from :meth:`step`.
    ``readings``: {sensor name: (n_cars, k)}; ``state``: the true
    :class:`~suspension_sim.sensors.base.PlantState`.  :attr:`loop` says which loop runs ("hybrid": compiled;
    "python").
    """

    def __init__(self, sim):
        from ..compiled.loop import plan

        self.sim = sim
        mode, self.loop_reason = plan(sim)
        self.loop = "hybrid" if mode is not None else "python"
        self._gen = None

    def start(self):
        from ..compiled.loop import run_steps
        from ..loop import one_blas_thread

        self.close()
        one_blas_thread()
        self.sim.loop = self.loop
        if self.loop == "hybrid":
            self._gen = run_steps(self.sim, "hybrid")
            try:
                readings = next(self._gen)
            except StopIteration:  # pragma: no cover - a run shorter than one control step
                self._gen = None
                return None
        else:
            readings = self.sim.start()
            self._gen = True
            if readings is None:  # pragma: no cover
                self._gen = None
                return None
        return self.sim.t, readings, self.sim.state

    def step(self, command: np.ndarray):
        if self._gen is None:
            raise RuntimeError("the run is over: call start()")
        try:
            if self._gen is True:
                readings = self.sim.control_step(command)
                if readings is None:
                    self._gen = None
                    return None
            else:
                try:
                    readings = self._gen.send(command)
                except StopIteration:
                    self._gen = None
                    return None
        except BaseException:
            self._gen = None
            self._restore()
            raise
        return self.sim.t, readings, self.sim.state

    @property
    def running(self) -> bool:
        return self._gen is not None

    def _restore(self):
        try:
            self.sim.plant.restore_road()
        except Exception:  # pragma: no cover - a plant without road state to restore
            pass

    def close(self):
        """End a run that is still going."""
        if self._gen is not None:
            if self._gen is not True:
                self._gen.close()
            self._gen = None
            self._restore()

    # -- restart of single cars (vector env autoreset) ------------------------------------------------
    def restart_cars(self, cars, road, road_vel=None) -> None:
        """Put the cars ``cars`` back near their static equilibrium on the road under them (wheels at the road
        height ``road`` (n_cars, n_corners), body heave at its mean, pitch and roll level, all at rest), at
        the current control instant, with their components restarted (:meth:`System.reset_cars`: actuator and
        effect states, sensor delay lines and holds, as at the start of a run); the other cars are untouched.
        A car that starts a run off that state (one heavier than it was levelled with, ``vehicle.levelled_with``,
        rests sagged: ``System.initial_q``/``initial_v``) restarts off it by as much.
        Called between :meth:`step` calls (the loop waits at a control instant after ``mj_step1``: the
        derived quantities are recomputed here)."""
        from ..loop import plant_state

        sim = self.sim
        P = sim.plant
        m, d = P.model, P.data
        q0, v0 = sim.initial_q, sim.initial_v  # per dof, as System.reset applies them
        cars = np.asarray(cars, dtype=np.intp).reshape(-1)
        for i in cars:
            d.qpos[P.body_q[i]] = 0.0
            d.qvel[P.body_v[i]] = 0.0
            d.qpos[P.body_q[i, 0]] = float(np.mean(road[i]))  # heave (the first body joint)
            d.qpos[P.wheel_q[i]] = road[i]
            d.qvel[P.wheel_v[i]] = 0.0
            for q, v in ((P.body_q[i], P.body_v[i]), (P.wheel_q[i], P.wheel_v[i])):
                if q0 is not None:
                    d.qpos[q] += q0[v]
                if v0 is not None:
                    d.qvel[v] = v0[v]
        mujoco.mj_step1(m, d)
        # the restarted cars' true state now, as at the start of a run: no last-step acceleration, no force yet
        road = np.asarray(road, dtype=float)
        road_vel = np.zeros_like(road) if road_vel is None else np.asarray(road_vel, dtype=float)
        zero = np.zeros((P.n, P.nc))
        state = plant_state(sim, float(sim.t), road, road_vel, np.zeros(m.nv), zero, zero)
        sim.reset_cars(cars, state)
