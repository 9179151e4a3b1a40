"""The discrepancy workflow (``suspension-sim diagnose``): calibrate a nominal model on measured data, locate
where it fails, name the missing effect from a library of candidates, add it, and show the gap shrink.

Modules: :mod:`.io` (reading records), :mod:`.model` (the model and its free parameters),
:mod:`.engine` (the project's simulator, batched over parameter sets), :mod:`.calibrate` (output-error fitting),
:mod:`.locate` (residual analysis), :mod:`.candidates` (the effect library), :mod:`.select` (greedy forward
selection), :mod:`.report` (outputs).  :mod:`.truth` generates synthetic test records only.

Python use::

    from suspension_sim.diagnose import diagnose
    rep = diagnose("rig.csv", "model.yaml", "out/", mapping={"Fc": ("force", 1.0)})
"""
from __future__ import annotations

from pathlib import Path


def diagnose(data, model, out, *, mapping=None, fs=None, split: float = 0.7, test=None, floors=None,
             candidates=None, max_effects: int = 3, rows=None, test_rows=None, nan: str = "error", sort=False,
             dedupe=False, resample=False, confirm: bool = True, plots: bool = True, log=None,
             screen_samples: int = 8000, test_skip=None, demean: bool = False, plausibility: bool = True,
             input_hold: str = "linear", workers: int | None = None) -> dict:
    """Run the whole workflow; returns the report dict (also written to ``out/report.json``).

    ``data``/``test``: file path(s) or :class:`~.io.Record`; ``model``: MODEL.yaml path or dict;
    ``floors``: {channel: noise/repeatability floor in channel units} overriding the estimate;
    ``plausibility=False`` fits even when :mod:`.plausibility` suspects the units (warnings only);
    ``input_hold``: what the measured inputs did between their samples (``linear``, ``bandlimited``, ``zoh``:
    :func:`.datafile.reconstruct`); ``workers``: threads fitting candidates side by side (default: the cores
    available, at most 4; the result does not depend on it)."""
    from .io import Record, load_record
    from .model import load_model
    from .report import build_report
    from .select import Selector

    spec = load_model(model)
    kw = dict(mapping=mapping, fs=fs, nan=nan, sort=sort, dedupe=dedupe, resample=resample, hold=input_hold)
    rec = data if isinstance(data, Record) else load_record(data, spec.kind, rows=rows, **kw)
    trec = None
    if test is not None:
        trec = test if isinstance(test, Record) else load_record(test, spec.kind, rows=test_rows, **kw)
    elif test_rows is not None:
        trec = load_record(data, spec.kind, rows=test_rows, **kw)
    if demean:
        _demean(rec, trec)
    from .plausibility import check as plausible  # units and scales against the model, before any fit

    plausible(rec, spec, override=not plausibility, log=log)
    sel = Selector(rec, spec, split=split, test_record=trec, floors=floors, candidates=candidates,
                   max_effects=max_effects, log=log, screen_samples=screen_samples, test_skip=test_skip,
                   workers=workers)
    D = sel.run()
    rep = build_report(D, Path(out), confirm=confirm, plots=plots)
    return rep


def _demean(rec, trec):
    """Subtract the training record's channel means from both records (repair flag ``--demean``)."""
    for d in (rec.inputs, rec.outputs):
        for k in list(d):
            m = float(d[k].mean())
            d[k] = d[k] - m
            if trec is not None:
                tgt = trec.inputs if d is rec.inputs else trec.outputs
                if k in tgt:
                    tgt[k] = tgt[k] - m
    rec.notes.append("channel means of the training record removed (--demean)")
