"""A simulation: build (:mod:`.build`) + loop (:mod:`.loop` or :mod:`.compiled.loop`) + log (:mod:`.log`).

``Simulation(scenarios).run()`` builds the system of one ensemble of structurally equal scenarios, steps it
with the compiled loop when every component has a kernel (else the Python loop; same results) and returns
one :class:`~suspension_sim.results.Result` per car.  :meth:`Simulation.start` / :meth:`control_step` step it
one control instant at a time (e.g. reinforcement learning).
"""
from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Callable, Sequence

from .build import STRUCTURE_KEYS, SpeedProfile, System, n_log_samples, structure_key  # noqa: F401  (public names)
from .compiled.loop import plan, run as run_compiled
from .config import Scenario, load_scenario
from .errors import SimulationDiverged
from .log import Logger, buffer_rows
from .loop import one_blas_thread, steps
from .results import Result


class Simulation(System):
    """One ensemble simulation. Build with structurally equal scenarios, then :meth:`run`."""

    def __init__(self, scenarios: Sequence[Scenario], source: str | None = None, n_threads: int = 1,
                 log_channels: str = "all"):
        super().__init__(scenarios, source)
        # "metrics": the compiled loop may log only the channels the metrics read (batches without time
        # series); a set of channel names: only those (the compiled loop); "all": every channel (the Python
        # loop always logs everything)
        self.log_channels = log_channels
        # callables hook(logger, j, t) run after each logged step j (time t), e.g. the live 3D viewer
        # (suspension_sim.viewer.attach_live_viewer); logger.ch[name][car, j] holds the step's log channels
        self.log_hooks: list = []
        # a long run's log goes to one Parquet file per car as it runs (suspension_sim.stream): these paths,
        # or temporary files when None (suspension-sim run points them into the run folder)
        self.stream_paths: list | None = None

    def new_logger(self) -> Logger:
        """The run's log: held whole when it fits in the log buffer (:func:`~suspension_sim.log.buffer_rows`),
        else in chunks streamed to :class:`~suspension_sim.stream.LogStream` (flat memory)."""
        n_log = n_log_samples(self.n_steps, self.log_every)
        cap = buffer_rows(self, n_log)
        sink = None
        if cap < n_log:
            from .stream import LogStream

            sink = LogStream(self, n_log, cap)
        return Logger(self, n_log=n_log, cap=cap, sink=sink)

    def results_of(self, logger: Logger, wall: float) -> list:
        """One :class:`Result` per car from a finished run's log."""
        logger.finish()
        if logger.streamed:
            return logger.sink.results(self, wall)
        return [Result.from_logger(logger, i, self, wall) for i in range(self.plant.n)]

    def run(self, progress: Callable[[float], None] | None = None) -> list:
        """Simulate the whole run with the scenario's controller; one Result per car.

        Runs the compiled loop (:mod:`suspension_sim.compiled`) when the components have kernels, else the
        Python loop (:mod:`suspension_sim.loop`); the results are the same.  :attr:`loop` tells which ran ("full", "hybrid",
        "python") and :attr:`loop_reason` why not the full compiled loop."""
        mode, self.loop_reason = plan(self)
        self.loop = mode or "python"
        with one_blas_thread(), _located(self):
            if mode is not None:
                logger = self.new_logger()
                try:
                    wall = run_compiled(self, mode, progress, logger)
                except SimulationDiverged as err:  # the log up to the stop goes with it (no rerun to see it)
                    logger.keep_until(err)
                    raise
                self.results = self.results_of(logger, wall)
                return self.results
            readings = self.start(progress)
            while readings is not None:
                readings = self.control_step(self.controller.step(self.t, readings))
            return self.results

    def start(self, progress: Callable[[float], None] | None = None) -> dict:
        """Step-wise use (e.g. reinforcement learning): reset and advance to the first control instant.

        Returns the sensor readings at t = 0; then call :meth:`control_step` with each command.  The physics
        is the loop of :meth:`run` itself (which is built on these two methods), so results are identical."""
        self._logger = self.new_logger()
        self._loop = steps(self, self._logger, progress)
        self.results = None
        return self.control_step(None)

    def control_step(self, command) -> dict | None:
        """Hold ``command`` (n_cars, n_corners) over one control step (zero-order hold) and return the
        readings at the next control instant, or None when the run has ended (then :attr:`results` holds one
        Result per car).  :attr:`t` is the time and :attr:`state` the true PlantState of the readings."""
        try:
            return self._loop.send(command) if command is not None else next(self._loop)
        except StopIteration as stop:
            self.results = self.results_of(self._logger, stop.value)
            return None
        except SimulationDiverged as err:  # the log up to the stop goes with it (no rerun to see it)
            self._logger.keep_until(err)
            raise


@contextlib.contextmanager
def _located(sim):
    """A divergence names the scenario file and the run (variant) it happened in."""
    try:
        yield
    except SimulationDiverged as err:
        car = err.car if err.car is not None and err.car < len(sim.scenarios) else 0
        raise err.locate(sim.source, sim.scenarios[car].name) from None


def simulate(scenario, progress=None, source: str | None = None):
    """Simulate one scenario (path or :class:`Scenario`; a scenario with variants returns a dict
    variant -> Result), or a list of structurally equal scenarios as one ensemble (list of Results)."""
    if isinstance(scenario, (str, Path)):
        source = str(scenario)
        scenario = load_scenario(scenario)
    if isinstance(scenario, Scenario):
        variants = scenario.expand(source)
        if len(variants) == 1 and not scenario.variants:
            return Simulation([scenario], source).run(progress)[0]
        return {name: Simulation([sc], source).run(progress)[0] for name, sc in variants}
    scs = list(scenario)
    return Simulation(scs, source).run(progress)
