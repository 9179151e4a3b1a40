"""Measured road profile from a CSV file (distance, height), resampled at the vehicle speed.

The file needs a distance column and a height column (``distance_column``, ``height_column``; names as
in the header, or 0-based column numbers for a file without a header: ``header: false``).  Units:
``distance_scale`` and ``height_scale`` multiply the values into metres (e.g. ``height_scale: 0.001``
for mm; ``height_unit: mm`` is a shortcut).  The distance must increase strictly and every value must be a
finite number; otherwise the run stops with a one-line :class:`~suspension_sim.errors.ScenarioError`
naming the file and the column.

Processing, in order:

1. ``detrend``: ``none``, ``mean`` (remove the mean) or ``linear`` (remove a least-squares line: the
   offset and slope of a measured profile are not road roughness; default);
2. ``smoothing``: moving average over this length in m (0 = none).  A tire does not follow texture much
   shorter than its contact patch (≈ 0.1–0.2 m); profilometer traces sampled at 1 mm carry texture and
   sensor noise that would otherwise reach the model as large road velocities;
3. the profile is placed so that its distance ``offset`` (m) lies under the front axle at the start line
   (road x = 0) and is faded in over ``fade_in`` m after it (default 0.5 m; the road is 0 behind the
   start line, where the rear wheels stand), so the run starts at equilibrium; with ``fade_in: 0`` the
   road behind the start line holds the value at ``offset``.  It is then evaluated at each wheel's
   distance x(t) (cubic spline through the samples, so any speed, constant or varying, resamples it).

Past the end of the profile (``beyond_end``): ``error`` (default: a run that needs more road than the file
has stops before it starts, naming the lengths), ``hold`` (last value) or ``repeat`` (the processed
profile is repeated; it may jump where it joins).

Relative paths are taken from the current working directory; ``~`` and environment variables
(``$VAR``) are expanded.  Example: the LTU teaching profile
``../shared/data/real/road_profile_ltu/ProfileData.csv`` (``Distance_m``, ``Profile_mm``; 20 m at 1 mm).
"""
from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Literal, Optional, Union

import numpy as np
from pydantic import Field, model_validator
from scipy.interpolate import CubicSpline
from scipy.ndimage import uniform_filter1d

from ..components import Params
from ..errors import ScenarioError
from ..registry import ROADS
from ._common import cosine_window, cosine_window_rate, edge_weight
from .base import Road

Column = Union[str, int]


class ProfileParams(Params):
    file: str = Field(..., description="CSV file path (relative to the working directory)")
    distance_column: Column = Field("Distance_m", description="header name or 0-based column number")
    height_column: Column = Field("Profile_mm", description="header name or 0-based column number")
    header: bool = Field(True, description="first line is a header")
    distance_scale: float = Field(1.0, gt=0, description="multiplies the distances into m")
    height_scale: Optional[float] = Field(None, gt=0, description="multiplies the heights into m")
    height_unit: Literal["m", "mm"] = Field("m", description="shortcut for height_scale (mm -> 0.001)")
    delimiter: Optional[str] = Field(None, description="column separator (default: detected)")
    detrend: Literal["none", "mean", "linear"] = "linear"
    smoothing: float = Field(0.0, ge=0, description="m, moving-average length (tire enveloping); 0 = none")
    offset: float = Field(0.0, description="m, profile distance under the front axle at the start line")
    fade_in: float = Field(0.5, ge=0, description="m, cosine fade-in after the start line")
    beyond_end: Literal["error", "hold", "repeat"] = "error"

    @model_validator(mode="after")
    def _unit(self):
        if self.height_scale is None:
            self.height_scale = 0.001 if self.height_unit == "mm" else 1.0
        return self


def _resolve(path: str) -> Path:
    return Path(os.path.expandvars(os.path.expanduser(path)))


@functools.lru_cache(maxsize=8)
def _read(path: str, mtime: float, dcol, hcol, header: bool, delimiter):
    import pandas as pd

    try:
        df = pd.read_csv(path, header=0 if header else None, sep=delimiter,
                         engine="python" if delimiter is None else "c")
    except Exception as err:  # noqa: BLE001 - any parse failure is a user error here
        raise ScenarioError(f"cannot read CSV: {str(err).splitlines()[0]}", source=path) from None
    cols = []
    for c in (dcol, hcol):
        key = c
        if isinstance(c, int) or (not header and isinstance(c, str) and c.isdigit()):
            idx = int(c)
            if idx >= df.shape[1]:
                raise ScenarioError(f"no column {idx} (the file has {df.shape[1]})", source=path, field=str(c))
            key = df.columns[idx]
        elif c not in df.columns:
            raise ScenarioError(f"missing column (columns: {', '.join(map(str, df.columns))})",
                                source=path, field=str(c))
        vals = pd.to_numeric(df[key], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(vals)
        if bad.any():
            i = int(np.argmax(bad))
            raise ScenarioError(f"{int(bad.sum())} missing or non-numeric value(s), first at data row {i + 1} "
                                f"({df[key].iloc[i]!r})", source=path, field=str(c))
        cols.append(vals)
    d, h = cols
    if d.size < 4:
        raise ScenarioError(f"needs at least 4 samples, has {d.size}", source=path, field=str(dcol))
    steps = np.diff(d)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise ScenarioError(f"distance must increase strictly (data rows {i + 1}->{i + 2}: {d[i]} -> {d[i + 1]})",
                            source=path, field=str(dcol))
    return d, h


def load_profile(p: ProfileParams) -> tuple[np.ndarray, np.ndarray]:
    """(distance in m from the profile's start, processed height in m) of a profile road's file."""
    path = _resolve(p.file)
    if not path.is_file():
        raise ScenarioError("profile file not found", source=str(path), field="road.params.file")
    d, h = _read(str(path), path.stat().st_mtime, p.distance_column, p.height_column, p.header, p.delimiter)
    d = (d - d[0]) * p.distance_scale
    h = h * p.height_scale
    if p.detrend == "mean":
        h = h - h.mean()
    elif p.detrend == "linear":
        h = h - np.polyval(np.polyfit(d, h, 1), d)
    if p.smoothing > 0:
        step = float(np.median(np.diff(d)))
        size = max(1, int(round(p.smoothing / step)))
        if size > 1:
            h = uniform_filter1d(h, size=size, mode="nearest")
    return d, h


@ROADS.register("profile")
class Profile(Road):
    """Measured profile from CSV (distance, height; scales, mm->m), detrended, resampled at the vehicle speed."""

    Params = ProfileParams

    def __init__(self, p, rng, ctx):
        super().__init__(p, rng, ctx)
        d, h = load_profile(p)
        self.d, self.h = d, h
        self.length = float(d[-1])
        if p.offset < 0 or p.offset >= self.length:
            raise ScenarioError(f"offset {p.offset} m lies outside the profile (0 to {self.length:.3f} m)",
                                source=str(_resolve(p.file)), field="road.params.offset")
        need = p.offset + float(ctx.distance)
        if p.beyond_end == "error" and need > self.length + 1e-9:
            raise ScenarioError(
                f"the profile is {self.length:.3f} m long from offset {p.offset} m, the run covers "
                f"{ctx.distance:.3f} m (shorten sim.duration or the speed, or set road.params.beyond_end: "
                f"hold|repeat)", source=str(_resolve(p.file)), field="road.params.beyond_end")
        self._spline = CubicSpline(d, h)

    def _along(self, x):
        """(x as an array, the position along the profile: offset, wrapped when it repeats; not clipped)."""
        x = np.asarray(x, dtype=float)
        s = x + self.p.offset
        if self.p.beyond_end == "repeat":
            s = np.where(s > self.length, np.mod(s, self.length), s)
        return x, s

    def height(self, t, x, track=0):
        p = self.p
        x, s = self._along(x)
        s = np.clip(s, 0.0, self.length)
        z = self._spline(s)
        if p.fade_in > 0:
            z = z * cosine_window(x, p.fade_in)
        else:
            z = np.where(x >= 0, z, self._spline(p.offset))
        return z

    def slopes(self, t, x, track=0):
        p = self.p
        x, s = self._along(x)
        sc = np.clip(s, 0.0, self.length)
        dz = edge_weight(s) * edge_weight(self.length - s) * self._spline(sc, 1)  # held beyond the ends
        if p.fade_in > 0:
            dz = dz * cosine_window(x, p.fade_in) + self._spline(sc) * cosine_window_rate(x, p.fade_in)
        else:
            dz = edge_weight(x) * dz
        return np.zeros_like(dz), dz
