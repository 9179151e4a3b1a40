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
