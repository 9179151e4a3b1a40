"""Asymmetric damping: separate compression and rebound coefficients, or a force–velocity damper map."""
from __future__ import annotations

from typing import Optional

import numba
import numpy as np
from pydantic import Field, field_validator, model_validator

from ..components import Params
from ..errors import ScenarioError
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class AsymmetricDampingParams(Params):
    c_comp: PerCornerNonNeg = Field(0.0, description="compression damping in N·s/m (travel rate < 0)")
    c_reb: PerCornerNonNeg = Field(0.0, description="rebound (extension) damping in N·s/m (travel rate > 0)")
    table: Optional[list[tuple[float, float]]] = Field(
        None, description="damper map: [[v, F], ...] points, v = travel rate in m/s (positive = rebound/"
        "extension), F = the damper's resisting force in N (same sign as v); interpolated linearly, extended "
        "linearly beyond the end points. Replaces c_comp/c_reb.")

    @field_validator("table")
    @classmethod
    def _table(cls, tab):
        if tab is None:
            return tab
        if len(tab) < 2:
            raise ValueError("a damper map needs at least two [v, F] points")
        vs = [p[0] for p in tab]
        if any(b <= a for a, b in zip(vs, vs[1:])):
            raise ValueError("damper map velocities must increase strictly")
        return tab

    @model_validator(mode="after")
    def _either(self):
        if self.table is not None and (_nonzero(self.c_comp) or _nonzero(self.c_reb)):
            raise ValueError("give either c_comp/c_reb or a table, not both")
        return self


def _nonzero(v) -> bool:
    return any(x != 0 for x in (v if isinstance(v, list) else [v]))


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner.  p = [n, c_comp, c_reb, xp_0 … xp_{m−1}, fp_0 … fp_{m−1}]: n = number of map
    points of this car (0 = no map: coefficients), m >= n the padded map length.  The map is interpolated
    linearly as ``np.interp`` does it (bisection to xp[j] <= v < xp[j+1], exact hits return fp[j]) and
    continued with the end segments' slopes beyond its ends."""
    n = int(p[0])
    if n == 0:
        c = p[2] if v > 0 else p[1]
        return -c * v
    m = (p.shape[0] - 3) // 2
    x0 = 3
    f0 = 3 + m
    if v < p[x0]:
        lo_slope = (p[f0 + 1] - p[f0]) / (p[x0 + 1] - p[x0])
        return -(p[f0] + lo_slope * (v - p[x0]))
    if v > p[x0 + n - 1]:
        hi_slope = (p[f0 + n - 1] - p[f0 + n - 2]) / (p[x0 + n - 1] - p[x0 + n - 2])
        return -(p[f0 + n - 1] + hi_slope * (v - p[x0 + n - 1]))
    if v >= p[x0 + n - 1]:
        return -p[f0 + n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if p[x0 + mid] <= v:
            lo = mid
        else:
            hi = mid
    j = lo
    if p[x0 + j] == v:
        return -p[f0 + j]
    slope = (p[f0 + j + 1] - p[f0 + j]) / (p[x0 + j + 1] - p[x0 + j])
    y = slope * (v - p[x0 + j]) + p[f0 + j]
    if y != y:  # as np.interp: non-finite table values
        y = slope * (v - p[x0 + j + 1]) + p[f0 + j + 1]
        if y != y and p[f0 + j] == p[f0 + j + 1]:
            y = p[f0 + j]
    return -y


@EFFECTS.register("asymmetric_damping")
class AsymmetricDamping(Effect):
    """Damper with different compression and rebound rates (c_comp, c_reb) or a measured force–velocity map.

    Force law (travel rate ``v``, positive = extension/rebound; positive F pushes the body up):

    - coefficients: ``F = −c_reb·v`` for ``v > 0`` (rebound), ``F = −c_comp·v`` for ``v < 0`` (compression);
    - map: ``F = −R(v)`` where ``R`` interpolates the ``table`` points ``[v, R]`` linearly and continues the
      first/last segment linearly beyond them.  ``R`` is the force the damper resists with (same sign as v:
      rebound forces positive, compression forces negative, as on a damper dyno plotted against extension
      velocity).  A map should pass through (0, 0); a non-zero R(0) acts as a constant force.

    It *adds* to the vehicle's linear damper (``vehicle.params.damping``); to replace the linear damper by
    this one, set that damping to 0.

    Signature in measured data: the residual force against travel rate has a kink at v = 0 (different slopes
    in compression and rebound), or follows the shape of the map (digressive/progressive knees).  Under a
    symmetric input the mean travel drifts ("jacking"): with more rebound than compression damping the
    suspension packs down (mean travel < 0) on rough roads; the travel response is skewed.
    """

    Params = AsymmetricDampingParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {"c_comp": FreeParameter("c", init=0.1, starts=(0.1, 0.0)),
                       "c_reb": FreeParameter("c", init=0.0, starts=(0.0, 0.1))}
    # with c_comp = c_reb = c this damper is the car's linear damping c: beside a free linear damping of its
    # corners the search fits c_reb − c_comp only (free_parameters.py: ``contains``) instead of two rates that
    # duplicate the damping (blind battery asym_van_sweep: the duplicated fit read the damping "driven to zero"
    # at correlation 1.000, and a sprung mass was named instead, 37× the floor)
    contains = {"damping": ("c_reb", "c_comp")}
    signature = ("residual force vs travel rate has a kink at v=0 (different compression/rebound slopes) or a "
                 "map shape; mean travel drifts (jacking/packing down) under symmetric excitation")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        tab = self.p.table  # one map, or one per car (None: that car has coefficients)
        per_car = tab is not None and (any(t is None for t in tab) or _per_car(tab))
        tables = [None if t is None else np.asarray(t, dtype=float)
                  for t in (tab if per_car else [tab] * self.ctx.n_cars)]
        if len(tables) != self.ctx.n_cars:
            raise ScenarioError("one damper map per car expected", field=f"effects.{self.name}.params.table")
        m = max((len(t) for t in tables if t is not None), default=0)
        p = self.pack(*([0.0] * (3 + 2 * m)))
        p[:, :, 1] = corner_array(self, "c_comp")
        p[:, :, 2] = corner_array(self, "c_reb")
        for i, t in enumerate(tables):
            if t is None:
                continue
            p[i, :, 0] = len(t)
            p[i, :, 3:3 + len(t)] = t[:, 0]
            p[i, :, 3 + m:3 + m + len(t)] = t[:, 1]
        return p, self.pack()


def _per_car(tab) -> bool:
    """True when the stacked parameter is a list of tables (cars with different maps)."""
    return bool(tab) and isinstance(tab[0], (list, tuple)) and bool(tab[0]) and isinstance(tab[0][0], (list, tuple))
