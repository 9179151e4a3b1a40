"""Reading measured records for the discrepancy workflow.

A record is a table of uniformly sampled channels: a ``time`` column in seconds (or a sample rate ``fs``),
inputs and outputs named from a fixed vocabulary per model kind (:data:`VOCAB`).  ``--map SRC=NAME*scale``
renames (and scales) source columns or MATLAB variables so that benchmark files work unedited.

Formats: CSV (``.csv``/``.txt``), Parquet (``.parquet``/``.pq``) and MATLAB ``.mat`` (``scipy.io.loadmat``;
every variable with one value per sample becomes a column, scalars are ignored).  Several files may be
given: their columns are merged side by side (they must have the same number of samples).

Bad data is an error with a one-line message (:class:`~suspension_sim.errors.ScenarioError`) naming the
problem, unless a repair flag says what to do:

- ``nan="drop"`` drops rows with a missing value in a used channel, ``nan="interp"`` interpolates them
  linearly (default ``"error"``);
- ``sort=True`` sorts rows by time; ``dedupe=True`` drops repeated time stamps (keeping the first);
- ``resample=True`` puts a non-uniform time base onto a uniform grid: when every step is a whole number of
  the usual (median) step (rows lost by a logger), onto that step, keeping every measured sample and filling
  the gaps linearly; otherwise linear interpolation onto the mean step.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import ScenarioError

_QC_OUT = ["body_acc", "wheel_acc", "susp_travel", "body_pos", "wheel_pos", "tire_force"]
VOCAB: dict[str, dict[str, list[str]]] = {
    "quarter_car": {"inputs": ["road", "force"], "outputs": _QC_OUT, "required_inputs": ["road"]},
    "sdof": {"inputs": ["force", "base"], "outputs": ["pos", "vel", "acc"], "required_inputs": []},
    "half_car": {"inputs": [f"{n}_{e}" for e in ("front", "rear") for n in ("road", "force")],
                 "outputs": [f"{n}_{e}" for e in ("front", "rear") for n in _QC_OUT] + ["pitch", "pitch_rate"],
                 "required_inputs": ["road_front", "road_rear"]},
    "damper": {"inputs": ["disp", "vel"], "outputs": ["force"], "required_inputs": ["disp"]},
}


class _Vocab(dict):
    """The vocabulary of every model kind: the fixed ones above, and any registered vehicle's from its
    corners (``body_acc_fl``, ``road_fl``, ..., ``pitch``, ``roll``) on first use."""

    def __missing__(self, kind):
        from ..registry import VEHICLES
        from .engine import input_names, output_names

        if kind not in VEHICLES.names():
            raise KeyError(kind)
        ins, req = input_names(kind)
        v = self[kind] = {"inputs": ins, "outputs": output_names(kind), "required_inputs": req}
        return v

    def __contains__(self, kind):
        from ..registry import VEHICLES

        return dict.__contains__(self, kind) or kind in VEHICLES.names()


VOCAB = _Vocab(VOCAB)
UNITS = {"road": "m", "force": "N", "body_acc": "m/s²", "wheel_acc": "m/s²", "susp_travel": "m", "body_pos": "m",
         "wheel_pos": "m", "tire_force": "N", "pos": "m", "vel": "m/s", "acc": "m/s²", "base": "m", "disp": "m",
         "pitch": "rad", "pitch_rate": "rad/s"}


@dataclass
class Record:
    """A uniformly sampled record: time ``t`` (s), inputs and outputs by vocabulary name (1-D arrays)."""

    kind: str
    t: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    source: str = ""
    notes: list[str] = field(default_factory=list)
    hold: str = "linear"  # the inputs between their samples: linear, bandlimited or zoh (datafile.reconstruct)

    @property
    def fs(self) -> float:
        return 1.0 / self.dt

    @property
    def dt(self) -> float:
        return float((self.t[-1] - self.t[0]) / (len(self.t) - 1))

    def __len__(self):
        return len(self.t)

    def slice(self, a: int, b: int) -> "Record":
        return Record(self.kind, self.t[a:b] - 0.0, {k: v[a:b] for k, v in self.inputs.items()},
                      {k: v[a:b] for k, v in self.outputs.items()}, self.source, list(self.notes), self.hold)


def parse_map(items: list[str] | None) -> dict[str, tuple[str, float]]:
    """``["SRC=NAME*scale", ...]`` -> {SRC: (NAME, scale)}."""
    out = {}
    for it in items or []:
        if "=" not in it:
            raise ScenarioError(f"--map expects SRC=NAME or SRC=NAME*scale, got {it!r}")
        src, _, rhs = it.rpartition("=")
        name, _, sc = rhs.partition("*")
        try:
            scale = float(sc) if sc else 1.0
        except ValueError:
            raise ScenarioError(f"--map {it!r}: scale {sc!r} is not a number") from None
        if not (np.isfinite(scale) and scale != 0):
            raise ScenarioError(f"--map {it!r}: the scale must be a finite number other than 0")
        out[src.strip()] = (name.strip(), scale)
    return out


def read_table(path: str | Path) -> pd.DataFrame:
    """One data file as a DataFrame (columns as in the file)."""
    from .datafile import check_data_file

    p = Path(path)
    check_data_file(p)  # exists, a file, size limit, not binary
    suf = p.suffix.lower()
    try:
        if suf in (".parquet", ".pq"):
            return pd.read_parquet(p)
        if suf == ".mat":
            from scipy.io import loadmat

            raw = loadmat(str(p), squeeze_me=False)
            cols = {}
            for k, v in raw.items():
                if k.startswith("__") or not isinstance(v, np.ndarray) or v.dtype.kind not in "biuf":
                    continue
                if v.ndim == 2 and 1 in v.shape and v.size > 1:
                    cols[k] = v.reshape(-1).astype(float)
            if not cols:
                raise ScenarioError("no per-sample variables (vectors) in the MATLAB file", source=str(path))
            n = max(len(c) for c in cols.values())
            return pd.DataFrame({k: c for k, c in cols.items() if len(c) == n})
        df = pd.read_csv(p, sep=None, engine="python")
        df = df.loc[:, [c for c in df.columns if not (str(c).startswith("Unnamed") and df[c].isna().all())]]
        return df
    except ScenarioError:
        raise
    except Exception as err:  # pragma: no cover - parser messages vary
        raise ScenarioError(f"cannot read data file: {str(err).splitlines()[0]}", source=str(path)) from None


def load_record(paths, kind: str, mapping: dict[str, tuple[str, float]] | None = None, fs: float | None = None,
                time_column: str = "time", nan: str = "error", sort: bool = False, dedupe: bool = False,
                resample: bool = False, rows: tuple[int, int] | None = None, hold: str = "linear") -> Record:
    """Read one or more files into a :class:`Record` of model kind ``kind`` (see module doc).  ``hold``: what
    the inputs did between their samples (``linear``, ``bandlimited``, ``zoh``; see
    :func:`.datafile.reconstruct`)."""
    from .datafile import HOLDS

    if hold not in HOLDS:
        raise ScenarioError(f"unknown input hold {hold!r} (one of {', '.join(HOLDS)})")
    if kind not in VOCAB:
        raise ScenarioError(f"unknown model kind {kind!r} (diagnose knows {', '.join(VOCAB)})")
    paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
    src = ", ".join(str(p) for p in paths)
    frames = [read_table(p) for p in paths]
    lens = {len(f) for f in frames}
    if len(lens) != 1:
        raise ScenarioError(f"files have different numbers of samples ({sorted(lens)}): mismatched lengths",
                            source=src)
    df = pd.concat([f.reset_index(drop=True) for f in frames], axis=1)
    df = df.loc[:, ~df.columns.duplicated()]
    if rows is not None:
        df = df.iloc[rows[0]:rows[1]].reset_index(drop=True)
    mapping = mapping or {}
    voc = VOCAB[kind]
    known = set(voc["inputs"]) | set(voc["outputs"])
    for s in mapping:
        if s not in df.columns:
            raise ScenarioError(f"--map: no column/variable {s!r} in the data (has: {', '.join(map(str, df.columns))})",
                                source=src)
    from .datafile import numeric_column  # a decimal comma or a word is named, not "missing values"

    chans: dict[str, np.ndarray] = {}
    tcol = None
    for col in df.columns:
        name, scale = mapping.get(col, (str(col), 1.0))
        if name == time_column or name == "time":
            tcol = numeric_column(df[col], str(col), src) * scale
            continue
        if name in known:
            if name in chans:
                raise ScenarioError(f"channel {name!r} given twice", source=src)
            chans[name] = numeric_column(df[col], str(col), src) * scale
        elif col in mapping:
            raise ScenarioError(f"unknown channel name {name!r} for a {kind} (inputs: {', '.join(voc['inputs'])}; "
                                f"outputs: {', '.join(voc['outputs'])})", source=src)
    # columns that are neither mapped nor known are ignored, but a file with none we know is an error
    missing = [r for r in voc["required_inputs"] if r not in chans]
    if kind == "sdof" and not ({"force", "base"} & set(chans)):
        missing.append("force or base")
    if missing:
        raise ScenarioError(f"missing required column(s) {', '.join(missing)} for a {kind} "
                            f"(use --map SRC=NAME to rename)", source=src)
    outs = [c for c in voc["outputs"] if c in chans]
    if not outs:
        raise ScenarioError(f"no output channel for a {kind} (any of: {', '.join(voc['outputs'])})", source=src)
    n = len(df)
    if tcol is None:
        if fs is None:
            raise ScenarioError(f"no '{time_column}' column: give one or the sample rate --fs", source=src)
        tcol = np.arange(n) / float(fs)
    elif fs is not None:
        raise ScenarioError("both a time column and --fs given: use one", source=src)
    notes = []
    # --- missing values ---------------------------------------------------------------------------------
    bad = ~np.isfinite(tcol)
    for k, v in chans.items():
        bad |= ~np.isfinite(v)
    if bad.any():
        if nan == "error":
            first = int(np.argmax(bad))
            which = [k for k, v in chans.items() if not np.isfinite(v[first])] or ["time"]
            raise ScenarioError(f"{int(bad.sum())} missing/NaN value(s), first at row {first} in {which[0]} "
                                f"(repair: --nan drop or --nan interp)", source=src)
        if nan == "drop" or not np.isfinite(tcol).all():
            keep = ~bad
            tcol = tcol[keep]
            chans = {k: v[keep] for k, v in chans.items()}
            notes.append(f"dropped {int(bad.sum())} rows with missing values")
        else:
            idx = np.arange(len(tcol))
            for k, v in chans.items():
                ok = np.isfinite(v)
                if not ok.all():
                    chans[k] = np.interp(idx, idx[ok], v[ok])
            notes.append(f"interpolated {int(bad.sum())} missing values")
    # --- time base ----------------------------------------------------------------------------------------
    if len(tcol) < 10:
        raise ScenarioError(f"only {len(tcol)} samples", source=src)
    d = np.diff(tcol)
    if np.any(d < 0):
        if not sort:
            raise ScenarioError(f"time is not sorted (first step back at row {int(np.argmax(d < 0)) + 1}; "
                                f"repair: --sort)", source=src)
        o = np.argsort(tcol, kind="stable")
        tcol = tcol[o]
        chans = {k: v[o] for k, v in chans.items()}
        notes.append("sorted by time")
        d = np.diff(tcol)
    if np.any(d == 0):
        if not dedupe:
            raise ScenarioError(f"{int(np.sum(d == 0))} duplicate time stamp(s) (first at row "
                                f"{int(np.argmax(d == 0)) + 1}; repair: --dedupe)", source=src)
        keep = np.concatenate([[True], d > 0])
        tcol = tcol[keep]
        chans = {k: v[keep] for k, v in chans.items()}
        notes.append(f"dropped {int((~keep).sum())} duplicate samples")
        d = np.diff(tcol)
    step = float(np.median(d))
    if np.max(np.abs(d - step)) > 1e-3 * step + 1e-9:
        if not resample:
            raise ScenarioError(f"non-uniform time steps ({d.min():.6g} … {d.max():.6g} s; repair: --resample)",
                                source=src)
        k = d / step
        if np.all(np.abs(k - np.round(k)) < 1e-3):
            # every step a whole number of the usual one: rows were lost (a logger's dropped samples).  The
            # record's own grid keeps every sample as measured and fills only the gaps; the mean step (the
            # record's span over fewer rows) would put every grid point between two samples, and the linear
            # interpolation would average the noise down (a 1 kHz record with 6 rows lost: 0.82× the noise)
            n_new = int(round((tcol[-1] - tcol[0]) / step)) + 1
            if n_new > 2 * len(tcol):  # a gap longer than the record (a clock jump, two records joined)
                j = int(np.argmax(d))
                raise ScenarioError(f"resample: a gap of {d[j]:.6g} s after row {j + 1} would fill {n_new - len(tcol)} "
                                    f"rows, more than the {len(tcol)} measured; cut the record at the gap", source=src)
            tg = tcol[0] + np.arange(n_new) * step
            idx = np.round((tcol - tcol[0]) / step).astype(int)
            gap = np.ones(n_new, bool)
            gap[idx] = False
            chans = {k_: _fill(tg, idx, gap, v) for k_, v in chans.items()}
            notes.append(f"{int(gap.sum())} missing rows filled by linear interpolation on the record's step")
        else:
            step = float((tcol[-1] - tcol[0]) / (len(tcol) - 1))
            tg = tcol[0] + np.arange(len(tcol)) * step
            chans = {k_: np.interp(tg, tcol, v) for k_, v in chans.items()}
            notes.append("resampled onto a uniform time grid")
        tcol = tg
    tcol = tcol - tcol[0]
    ins = {k: chans[k] for k in voc["inputs"] if k in chans}
    if kind == "damper" and "vel" not in ins:
        ins["vel"] = np.gradient(ins["disp"], tcol)
        notes.append("damper velocity derived from displacement (central differences)")
    return Record(kind, tcol, ins, {k: chans[k] for k in outs}, src, notes, hold)


def _fill(tg, idx, gap, v):
    """``v`` measured at the grid points ``idx`` of ``tg``, kept there, linear across the missing ones."""
    out = np.empty(len(tg))
    out[idx] = v
    out[gap] = np.interp(tg[gap], tg[idx], v)
    return out


def record_from_arrays(kind: str, t, inputs: dict, outputs: dict, source: str = "arrays") -> Record:
    """A Record from in-memory arrays (same checks as files, no repair)."""
    df = pd.DataFrame({"time": np.asarray(t, float), **{k: np.asarray(v, float) for k, v in inputs.items()},
                       **{k: np.asarray(v, float) for k, v in outputs.items()}})
    tmp = _MemFrame(df)
    return tmp.load(kind, source)


class _MemFrame:
    def __init__(self, df):
        self.df = df

    def load(self, kind, source):
        import tempfile

        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "rec.parquet"
            self.df.to_parquet(p)
            rec = load_record(p, kind)
        rec.source = source
        return rec
