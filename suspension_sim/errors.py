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
    """The simulation produced NaN or a runaway state."""

    def __init__(self, time: float, state: dict, hint: str, car: int | None = None):
        self.time = time
        self.state = state
        self.hint = hint
        self.car = car
        st = ", ".join(f"{k}={v:.4g}" for k, v in state.items())
        where = f" (car {car})" if car is not None else ""
        super().__init__(f"simulation diverged at t={time:.4f} s{where}: {st}. Hint: {hint}")
