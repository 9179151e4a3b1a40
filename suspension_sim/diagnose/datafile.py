"""Checks of a measured-data file while it is read (called from :mod:`.io`): the file itself (exists, a file,
within the size limit, text for a CSV) and each column (numbers, with a decimal comma or a word named).  The
checks of the record against the model come after reading, in :mod:`.plausibility`."""
from __future__ import annotations

import numpy as np

from ..errors import ScenarioError


def check_data_file(path) -> None:
    """A data file before it is parsed: exists, a regular file, within the ``data_mb`` limit, and a CSV is
    text (not binary)."""
    from pathlib import Path

    from .. import limits

    p = Path(path)
    src = str(path)
    if not p.exists():
        raise ScenarioError("data file not found", source=src)
    if p.is_dir():
        raise ScenarioError("is a directory, not a data file (CSV, Parquet or .mat)", source=src)
    if not p.is_file():
        raise ScenarioError("not a regular file (a data file is expected)", source=src)
    size = p.stat().st_size
    if size == 0:
        raise ScenarioError("the data file is empty", source=src)
    limits.check("data_mb", size / 1e6, source=src, what="data file size in MB")
    if p.suffix.lower() not in (".parquet", ".pq", ".mat"):
        with open(p, "rb") as fh:
            head = fh.read(65536)
        if b"\x00" in head:
            raise ScenarioError("a binary file, not CSV text (Parquet files end in .parquet, MATLAB files in .mat)",
                                source=src)


_DEC_COMMA = None


def numeric_column(series, column: str, source: str):
    """A data column as floats; a decimal comma or a word where a number belongs is named, not reported as
    missing values.  Empty cells stay missing (NaN) for ``--nan``."""
    import re

    import pandas as pd

    global _DEC_COMMA
    if _DEC_COMMA is None:
        _DEC_COMMA = re.compile(r"^\s*[-+]?\d+,\d+(?:[eE][-+]?\d+)?\s*$")
    vals = pd.to_numeric(series, errors="coerce")
    if not pd.api.types.is_numeric_dtype(series.dtype):
        bad = vals.isna() & series.notna() & (series.astype(str).str.strip() != "")
        if bad.any():
            i = int(np.argmax(bad.to_numpy()))
            v = str(series.iloc[i])
            if _DEC_COMMA.match(v):
                raise ScenarioError(f"column {column!r} uses a decimal comma ({v!r} at row {i}): write numbers with "
                                    "a decimal point", source=source)
            if v.strip().lower() not in ("nan", "na", "n/a", "null", "none", "-"):
                raise ScenarioError(f"column {column!r}: {v[:40]!r} at row {i} is not a number", source=source)
    return vals.to_numpy(dtype=float)


# ------------------------------------------------------------------------------------------------------
# the measured inputs between their samples
# ------------------------------------------------------------------------------------------------------
HOLDS = ("linear", "bandlimited", "zoh")
SINC_HALF_WIDTH = 32  # samples each side of a band-limited interpolation (Blackman-windowed sinc)


def reconstruct(u, dt: float, t, hold: str = "linear"):
    """The sampled signal ``u`` (sample k at time k·dt) at times ``t`` between and beyond its samples.

    ``hold`` says what the signal did between the samples:

    - ``linear``: straight lines between the samples (the default);
    - ``bandlimited``: the band-limited signal the samples were taken from (Shannon reconstruction with a
      Blackman-windowed sinc of ±32 samples; the right choice for a signal that was low-pass filtered before
      it was sampled, or generated through a reconstruction filter, as the Silverbox input is);
    - ``zoh``: held constant from one sample to the next (a digital command through a DAC without a filter).

    Before the first and after the last sample the end values are held."""
    u = np.ascontiguousarray(u, float)
    x = np.asarray(t, float) / dt
    if hold == "linear":
        return np.interp(x, np.arange(len(u)), u)
    if hold == "zoh":
        return u[np.clip(np.floor(x + 1e-9).astype(np.int64), 0, len(u) - 1)]
    if hold == "bandlimited":
        return _sinc_interp(u, np.ascontiguousarray(x), SINC_HALF_WIDTH)
    raise ScenarioError(f"unknown input hold {hold!r} (one of {', '.join(HOLDS)})")


def _sinc_interp_py(u, x, K):
    n = u.shape[0]
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        xi = x[i]
        n0 = int(np.floor(xi))
        frac = xi - n0  # in [0, 1], 1.0 itself when xi is a tiny negative number (rounding)
        if frac < 1e-12 or frac > 1.0 - 1e-12:  # on a sample
            out[i] = u[min(max(n0 + (1 if frac > 0.5 else 0), 0), n - 1)]
            continue
        acc = 0.0
        wsum = 0.0
        for m in range(-K + 1, K + 1):
            d = frac - m  # distance from sample n0 + m, in samples (never 0 here)
            w = np.sin(np.pi * d) / (np.pi * d) * (0.42 + 0.5 * np.cos(np.pi * d / K) + 0.08 * np.cos(2 * np.pi * d / K))
            j = min(max(n0 + m, 0), n - 1)
            acc += w * u[j]
            wsum += w
        out[i] = acc / wsum  # normalised: a constant signal stays exactly constant
    return out


try:
    import numba as _nb

    _sinc_interp = _nb.njit(cache=True)(_sinc_interp_py)
except ImportError:  # pragma: no cover
    _sinc_interp = _sinc_interp_py
