"""Bump and rebound stops: elastic (optionally damped) end stops beyond a free travel."""
from __future__ import annotations

from typing import Literal, Optional

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, PerCornerPos, corner_array, step_mean_column
from ..free_parameters import FreeParameter
from .base import Effect


class BumpStopParams(Params):
    gap: PerCornerPos = Field(0.125, description="free travel each way from static equilibrium in m "
                              "(the thesis's D/2)")
    gap_compression: Optional[PerCornerPos] = Field(None, description="free travel in compression in m "
                                                    "(default: gap)")
    gap_extension: Optional[PerCornerPos] = Field(None, description="free travel in extension in m (default: gap)")
    stiffness: PerCornerNonNeg = Field(40000.0, description="stop stiffness K_es in N/m")
    damping: PerCornerNonNeg = Field(0.0, description="stop damping in N·s/m, acting only while a stop is "
                                     "engaged, and never pulling")
    step_force: Literal["start", "mean"] = Field(
        "start", description="the force applied over a physics step. start: the law at the travel at the start "
        "of the step (held over the step: first order in it, a negative damping k·dt/2 while engaged and up to "
        "k·|v|·dt of impulse per step at a contact); mean: the law's exact mean over the step with the travel "
        "taken as linear through it (s + v·τ; second order; a contact inside the step gets its part of the step)")


@numba.njit(cache=True)
def _ramp_mean(a0, a1, b0, b1, dt):
    """The mean over τ in [0, dt] of ``b0 + b1·τ`` where both ``a0 + a1·τ > 0`` (the stop engaged) and
    ``b0 + b1·τ > 0`` (it pushes), zero elsewhere: two linear functions of τ, so the part of the step where both
    hold is one interval, over which the force is linear (its mean is the value at the interval's middle)."""
    lo = 0.0
    hi = dt
    for c0, c1 in ((a0, a1), (b0, b1)):
        if c1 > 0.0:
            lo = max(lo, -c0 / c1)
        elif c1 < 0.0:
            hi = min(hi, -c0 / c1)
        elif not c0 > 0.0:
            return 0.0
    if not hi > lo:
        return 0.0
    return (hi - lo) / dt * (b0 + b1 * 0.5 * (lo + hi))


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [g_c, g_e, k, c, step mean (1/0)], st = [engaged].  With the step mean,
    the law's mean over the step along the travel ``s + v·τ`` (:func:`_ramp_mean`; ``v`` held, so the damping
    term ``c·v`` is constant while engaged)."""
    pen_c = -p[0] - s
    pen_e = s - p[1]
    st[0] = (1.0 if pen_c > 0 else 0.0) - (1.0 if pen_e > 0 else 0.0)
    if p[4] != 0.0:
        if s != s or v != v:
            return s + v  # NaN propagates
        # compression: engaged while −g_c − s − v·τ > 0, pushing k·(−g_c − s − v·τ) − c·v up (never pulling);
        # extension: engaged while s + v·τ − g_e > 0, pulling k·(s + v·τ − g_e) + c·v down (never pushing)
        return (_ramp_mean(pen_c, -v, p[2] * pen_c - p[3] * v, -p[2] * v, dt)
                - _ramp_mean(pen_e, v, p[2] * pen_e + p[3] * v, p[2] * v, dt))
    f_c = 0.0
    f_e = 0.0
    if pen_c > 0:
        x = p[2] * pen_c - p[3] * v
        f_c = x if x > 0.0 else 0.0  # max(0, x), NaN propagates
        if x != x:
            f_c = x
    if pen_e > 0:
        x = -p[2] * pen_e - p[3] * v
        f_e = x if x < 0.0 else 0.0
        if x != x:
            f_e = x
    return f_c + f_e


NO_STOP = 10.0  # where a gap the fitted window never reaches goes, in units of the largest training travel


@EFFECTS.register("bump_stop")
class BumpStop(Effect):
    """Elastic end stops: a stiff spring (optionally damped) engages beyond the free travel each way.

    Force law, with travel ``s`` (m from equilibrium, positive = extension), rate ``v``, compression gap
    ``g_c`` and extension gap ``g_e`` (both > 0), stiffness ``k`` and damping ``c``:

    - compression stop, engaged when ``s < −g_c``: ``F = max(0, k·(−g_c − s) − c·v)`` (pushes the body up);
    - extension (rebound) stop, engaged when ``s > g_e``: ``F = min(0, −k·(s − g_e) − c·v)`` (pulls it down);
    - zero inside the free travel.

    The damping acts only while a stop is engaged, and is clipped so that a stop never pulls (a separating
    stop with fast rebound gives zero force, not adhesion).  With ``c = 0`` this is the thesis's elastic
    limit stop ``K_es·S*·(z − (D/2)·sgn z)`` with ``gap = D/2`` (thesis: K_es = 40 kN/m, D = 25 cm).

    Like every effect the force is computed once per physics step and held over it (``step_force: start``, the
    default): the integrator (RK4 included) then sees the stop spring as a constant force, first order in the step
    (a negative damping k·dt/2 while engaged, and a contact inside the step lands on a step boundary).  With
    ``step_force: mean`` the force held is the law's exact mean over the step along the travel ``s + v·τ``: second
    order (tests/test_effects.py; on the thesis Ch. 4 rig replaying a run that bursts 0.85 m past the stops, the
    body's error at 0.0625 ms falls from 0.34 mm to 0.13 mm, 0.042 mm with the orifice damper's mean too).

    Signature in measured data: the restoring force rises sharply beyond a travel threshold (residual force
    vs travel is zero inside a band and grows steeply outside it), the travel distribution is clipped near
    ±gap, and body acceleration shows spikes (harshness) whenever the stroke reaches a stop; strongest on
    large bumps/potholes and heavy loads.
    """

    Params = BumpStopParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py): each side's gap on the scale
    # of the largest travel to that side (s_comp, s_ext), from three starts: both stops engaged, compression
    # only, extension only (a gap beyond the largest travel is a stop that never engages: see fitted_notes).
    # A gap the fitted window never reaches goes to NO_STOP times the largest training travel (``unseen``):
    # the data say nothing about a stop they never reach, and one left where its start put it (1.5×) is a stop
    # that held-out data run into (blind battery stops_suv_comp_only: a compression stop fitted within 0.3 %,
    # its unseen extension gap at 36 mm against 48 mm of held-out extension, held-out NRMSE 0.117 → 0.110,
    # and a cubic spring named in its place)
    free_parameters = {"gap_compression": FreeParameter("s_comp", init=0.7, lo=1e-6, hi=NO_STOP, starts=(0.5, 0.8, 1.5),
                                                        size=False, unseen=NO_STOP),
                       "gap_extension": FreeParameter("s_ext", init=0.7, lo=1e-6, hi=NO_STOP, starts=(0.5, 1.5, 0.8),
                                                      size=False, unseen=NO_STOP),
                       "stiffness": FreeParameter("max(k, F/s)", init=2.0),
                       # contact damping while engaged (rubber and hydraulic stops dissipate; the law never pulls),
                       # started undamped: a damped stop fitted without it took its dissipation into the linear
                       # damping and did not improve held-out data (blind battery stops_truck_damped: gaps within
                       # 2 %, ΔBIC −14 984, held-out 0.0244 → 0.0246 against a floor of 0.0198)
                       "damping": FreeParameter("c", init=0.0)}
    signature = ("residual force vs travel is zero inside a band and steep outside; travel clipped near ±gap; "
                 "body-acceleration spikes at end of stroke")

    kernel = staticmethod(_kernel)

    @staticmethod
    def fitted_notes(params: dict, travel, ci95: dict | None = None) -> dict:
        """What fitted parameters mean on a record whose travel (m, this effect's corners) is ``travel``: a
        gap beyond the largest travel to its side, or whose 95 % interval reaches beyond it (``ci95``), is a
        stop that never engages there, or cannot be told from one that never does."""
        import numpy as np

        s = np.asarray(travel, float)
        out = {}
        for pn, side, reach in (("gap_compression", "compression", float(np.max(-s))),
                                ("gap_extension", "extension", float(np.max(s)))):
            g = params.get(pn)
            if g is None:
                continue
            up = ((ci95 or {}).get(pn) or [g, g])[1]
            if g >= reach:
                out[pn] = (f"no {side} stop: the gap ({1e3 * g:.1f} mm) lies beyond the largest {side} in the "
                           f"record ({1e3 * reach:.1f} mm)")
            elif up >= reach:
                out[pn] = (f"no {side} stop: the gap ({1e3 * g:.1f} mm, 95 % interval up to {1e3 * up:.1f} mm) "
                           f"cannot be told from one beyond the largest {side} in the record ({1e3 * reach:.1f} mm)")
        return out

    def gaps(self):
        """(compression gap, extension gap) per corner, m (for the metrics and the 3D view)."""
        gap = corner_array(self, "gap")
        g_c = gap if self.p.gap_compression is None else corner_array(self, "gap_compression")
        g_e = gap if self.p.gap_extension is None else corner_array(self, "gap_extension")
        return g_c, g_e

    def kernel_data(self):
        g_c, g_e = self.gaps()
        mean = step_mean_column(self)  # per car
        return (self.pack(g_c, g_e, corner_array(self, "stiffness"), corner_array(self, "damping"), mean),
                self.pack(0.0))

    def kernel_signals(self):
        """``engaged``: +1 on the compression stop, −1 on the extension stop, 0 free."""
        return {"engaged": 0}
