"""Errors a user can cause, and errors a simulation can end with.

Both print as one line in the CLI (no traceback): a user mistake names the file, the field and the problem;
a diverging run names the time, the state and a hint.
"""
from __future__ import annotations


class ScenarioError(ValueError):
    """A bad scenario, parameter or input file. ``str(err)`` is the one-line message shown to the user."""

    def __init__(self, message: str, source: str | None = None, field: str | None = None):
        self.source = source
        self.field = field
        parts = []
        if source:
            parts.append(str(source))
        if field:
            parts.append(field)
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)


class SimulationDiverged(RuntimeError):
    """The simulation produced NaN or a runaway state.  ``source`` (scenario file) and ``variant`` (the run's
    name) are added by :meth:`locate` where they are known, so the message says which run diverged.

    :attr:`log` is the run's log up to the stop (one DataFrame per car, the columns of ``Result.ts``), kept by
    :class:`~suspension_sim.simulation.Simulation` so that a diverged run need not be run again to show what led
    to the stop; None where no log was kept (an exception raised elsewhere, a log streamed to disk in chunks,
    or one that crossed a process boundary: pickling drops it)."""

    def __init__(self, time: float, state: dict, hint: str, car: int | None = None, source: str | None = None,
                 variant: str | None = None):
        self.time = time
        self.state = state
        self.hint = hint
        self.car = car
        self.source = source
        self.variant = variant
        self._log_src = None  # a callable that builds the log (it references the log buffer until .log is read)
        self._log = None
        super().__init__(self._message())

    def keep_log(self, build) -> "SimulationDiverged":
        """Keep the log up to the stop: ``build()`` returns it (one DataFrame per car), called on the first use of
        :attr:`log`, so a stop nobody looks at costs no copy of the log.  Returns self."""
        self._log_src, self._log = build, None
        return self

    @property
    def log(self):
        """Per car, the DataFrame of every log instant before the stop (t first), or None (see the class)."""
        if self._log is None and self._log_src is not None:
            self._log, self._log_src = self._log_src(), None
        return self._log

    def _message(self) -> str:
        st = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in self.state.items())
        where = f" (car {self.car})" if self.car is not None else ""
        head = ": ".join(str(x) for x in (self.source, self.variant) if x)
        return (f"{head + ': ' if head else ''}simulation diverged at t={self.time:.4f} s{where}: "
                f"{st or 'no state recorded'}. Hint: {self.hint}")

    def locate(self, source: str | None = None, variant: str | None = None) -> "SimulationDiverged":
        """Add the scenario file and the run's name (where not known yet); returns self."""
        self.source = self.source or source
        self.variant = self.variant or variant
        self.args = (self._message(),)
        return self

    def __reduce__(self):
        return (type(self), (self.time, self.state, self.hint, self.car, self.source, self.variant))
