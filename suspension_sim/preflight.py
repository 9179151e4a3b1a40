"""Everything ``run`` checks before the first step, callable without stepping (``validate`` runs it).

:func:`build` validates a scenario file (with ``--set`` overrides), expands its variants and builds each
variant's :class:`~suspension_sim.simulation.Simulation` (the MuJoCo model, every component, the roads): the
checks that used to surface only in ``run`` (integrator limits, effects on a model without tires, manoeuvres
on a quarter car, ...) then fail in ``validate`` too.  Memory no longer grows with the duration (a log longer
than the buffer streams to disk in chunks, :mod:`suspension_sim.stream`): :func:`check_log_memory` checks the
log buffer against the ``log_gb`` limit of :mod:`suspension_sim.limits`, and :func:`check_disk` refuses a
run whose time series would not fit on the disk.
"""
from __future__ import annotations

from pathlib import Path

from . import limits
from .errors import ScenarioError
from .log import log_channels_estimate


def check_log_memory(sim, source: str | None = None) -> None:
    """The log buffer (the whole log, or one chunk of a streamed log) against the ``log_gb`` limit."""
    from .log import buffer_rows
    from .simulation import n_log_samples

    n_log = n_log_samples(sim.n_steps, sim.log_every)
    rows = buffer_rows(sim, n_log)
    gb = rows * sim.plant.n * log_channels_estimate(sim) * 8 / 1e9
    limits.check("log_gb", gb, source=source, field="sim.duration",
                 what=f"the run's log buffer ({rows} instants; a larger sim.log_dt makes it smaller) in GB")


def check_disk(sims, target: Path, timeseries: bool = True, source: str | None = None) -> None:
    """Refuse a run whose time series would not fit on the disk that holds ``target`` (the run folder, which
    need not exist yet): the estimate is the uncompressed log (instants × channels × 8 bytes per variant),
    an upper bound of the Parquet file for noisy signals, against the free space, before any step."""
    import shutil

    from .simulation import n_log_samples

    if not timeseries or not sims:
        return
    need = sum(n_log_samples(sim.n_steps, sim.log_every) * sim.plant.n * (log_channels_estimate(sim) + 1) * 8
               for _, sim in sims)
    place = Path(target).absolute()
    while not place.exists() and place.parent != place:
        place = place.parent
    free = shutil.disk_usage(place).free
    if need > free:
        raise ScenarioError(f"the run's time series (~{need / 1e9:.3g} GB) would not fit on the disk at {place} "
                            f"({free / 1e9:.3g} GB free); use a larger sim.log_dt, a shorter sim.duration, or "
                            "outputs.timeseries: false", source=source, field="sim.duration")


def build(scenario: str | Path, overrides: list[str] | None = None):
    """(scenario, [(variant name, Simulation), ...]) with every pre-run check done; nothing is stepped."""
    from .config import load_scenario
    from .simulation import Simulation

    src = str(scenario)
    sc = load_scenario(scenario, overrides or [])
    sims = []
    for vname, vsc in sc.expand(src):
        try:
            sim = Simulation([vsc], src)
            check_log_memory(sim, src)
        except ScenarioError as err:
            if not sc.variants:
                raise
            head = ": ".join(str(x) for x in (err.source, err.field) if x)  # name the variant too
            msg = str(err)[len(head) + 2:] if head and str(err).startswith(head + ": ") else str(err)
            raise ScenarioError(msg, source=err.source or src,
                                field=f"variants.{vname}:{err.field}" if err.field else f"variants.{vname}") from None
        sims.append((vname, sim))
    return sc, sims


__all__ = ["build", "check_disk", "check_log_memory", "log_channels_estimate", "ScenarioError"]
