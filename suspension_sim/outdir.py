"""Output folders: never overwrite a user's results by accident, never mix old results with new ones.

:func:`prepare` is called by every command that writes a folder (``run``, ``diagnose``, ``compare``,
``batch``): an existing, non-empty folder is refused unless ``overwrite`` is given; with ``overwrite`` the
files and sub-folders this package writes are removed first (so stale variant folders of an earlier run do
not mix with the new ones), and nothing else is touched.  :func:`unique_default` makes a default
timestamped folder that does not exist yet.  :func:`write_atomic` writes a file by rename, so a reader (or
a crash) never sees it half written.
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

from .errors import ScenarioError

# what our commands write into an output folder (top level); run folders' variant sub-folders are recognised
# by these files inside them
OWN_FILES = {"summary.json", "timing.json", "timeseries.parquet", "scenario.resolved.yaml", "viewer.html",
             "report.html", "report.json", "model.fitted.yaml", "model.fitted.xml", "summary.parquet",
             "sweep.resolved.json", ".summary.tmp", "errors.txt"}
OWN_DIRS = {"plots", "parts", "timeseries"}


def _is_own_subfolder(p: Path) -> bool:
    return p.is_dir() and any((p / f).exists() for f in ("summary.json", "scenario.resolved.yaml", "timing.json"))


def prepare(folder: Path, overwrite: bool, option: str = "--out", allow_resume: bool = False) -> Path:
    """Check (and with ``overwrite`` clear) an output folder; returns it.  ``allow_resume``: an existing
    folder is fine as is (``batch`` resumes into its own folder)."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ScenarioError(f"{option} exists and is not a folder", source=str(folder))
    if not folder.exists():
        return folder
    try:
        entries = list(folder.iterdir())
    except OSError as err:
        raise ScenarioError(f"{option}: cannot read the folder: {err.strerror}", source=str(folder)) from None
    if not entries or allow_resume:
        return folder
    if not overwrite:
        raise ScenarioError(f"{option} folder already exists and is not empty: give --overwrite to replace "
                            "its results, or another folder", source=str(folder))
    for p in entries:
        if p.name in OWN_FILES and p.is_file():
            p.unlink()
        elif p.is_dir() and not p.is_symlink() and (p.name in OWN_DIRS or _is_own_subfolder(p)):
            shutil.rmtree(p)
        elif p.name.startswith(".") and p.name.endswith(".tmp") and p.is_file():
            p.unlink()
    return folder


def unique_default(folder: Path) -> Path:
    """``folder`` if it does not exist, else ``folder-2``, ``folder-3``, ..."""
    folder = Path(folder)
    if not folder.exists():
        return folder
    k = 2
    while Path(f"{folder}-{k}").exists():
        k += 1
    return Path(f"{folder}-{k}")


def write_atomic(path: Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename (atomic on POSIX),
    flushed to disk first."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(tmp, mode, **({} if isinstance(data, bytes) else {"encoding": "utf-8"})) as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return path
