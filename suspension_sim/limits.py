"""Resource limits on what a user's input may make the program do, checked before the work starts.

Each limit has a default that no ordinary use comes near and can be raised (or lowered) with an environment
variable ``SUSPENSION_SIM_LIMIT_<NAME>`` (e.g. ``SUSPENSION_SIM_LIMIT_SWEEP_RUNS=5000000``); a refusal is a
one-line :class:`~suspension_sim.errors.ScenarioError` naming the limit and that variable.

=================  ==========  ==========================================================================
name               default     what it bounds
=================  ==========  ==========================================================================
``file_mb``        4           size of a YAML file (scenario, sweep, model) in MB, before it is parsed
``yaml_nodes``     200000      YAML nodes of a file after alias expansion (``&a``/``*a`` bombs)
``yaml_depth``     64          nesting depth of a YAML file
``sweep_runs``     1000000     runs of one sweep (grid × lists × samples × seeds), counted before expanding
``steps``          2e9         physics steps of one run (duration / dt)
``log_samples``    2e9         logged instants of one run (duration / log_dt)
``log_gb``         8           memory of one run's (or one batch task's) log buffer in GB: the whole log when it
                               fits in 64 MB per car and 512 MB in all, else one chunk (a long log streams to disk, see ``stream.py``)
``data_mb``        2000        size of one measured-data file for ``diagnose`` in MB
=================  ==========  ==========================================================================
"""
from __future__ import annotations

import os

from .errors import ScenarioError

DEFAULTS: dict[str, float] = {
    "file_mb": 4.0,
    "yaml_nodes": 200_000,
    "yaml_depth": 64,
    "sweep_runs": 1_000_000,
    "steps": 2e9,
    "log_samples": 2e9,
    "log_gb": 8.0,
    "data_mb": 2000.0,
}
WHAT = {
    "file_mb": "file size (MB)",
    "yaml_nodes": "YAML nodes after alias expansion",
    "yaml_depth": "YAML nesting depth",
    "sweep_runs": "runs in one sweep",
    "steps": "physics steps of one run (sim.duration / sim.dt)",
    "log_samples": "logged instants of one run (sim.duration / sim.log_dt)",
    "log_gb": "log buffer memory (GB)",
    "data_mb": "data file size (MB)",
}


def env_name(name: str) -> str:
    return f"SUSPENSION_SIM_LIMIT_{name.upper()}"


def get(name: str) -> float:
    """The limit ``name`` (its default, or the value of ``SUSPENSION_SIM_LIMIT_<NAME>``)."""
    raw = os.environ.get(env_name(name))
    if raw is None or not raw.strip():
        return DEFAULTS[name]
    try:
        v = float(raw)
    except ValueError:
        raise ScenarioError(f"{env_name(name)}={raw!r} is not a number") from None
    if not v > 0:
        raise ScenarioError(f"{env_name(name)}={raw!r} must be > 0")
    return v


def how_to_raise(name: str) -> str:
    return f"limit {name}={_fmt(get(name))}; raise it with the environment variable {env_name(name)}"


def check(name: str, value: float, source: str | None = None, field: str | None = None, what: str | None = None):
    """Refuse ``value`` above limit ``name`` with a one-line error naming the limit and how to raise it."""
    lim = get(name)
    if value > lim:
        raise ScenarioError(f"{what or WHAT[name]} would be {_fmt(value)}, above the {how_to_raise(name)}",
                            source=source, field=field)


def _fmt(v: float) -> str:
    return f"{v:.4g}" if v != int(v) or abs(v) >= 1e7 else str(int(v))
