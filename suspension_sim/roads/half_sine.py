"""Half-sine bump (or dip): z = h·sin(π (s − s0)/L) for s0 ≤ s ≤ s0 + L, 0 otherwise.

The thesis's excitation mode I (Vallurupalli 1996, §2.2.1) uses a half-sinusoid "bump input" for an
off-road profile or a road under construction.  Unlike the 1 − cos bump its slope jumps at both ends
(the road velocity steps to ±π h/L · speed), which makes it a harsher test.  Given in space (``length``, m)
or time (``duration``, s); ``repeat``/``period`` give a row of them; ``track`` limits it to one side.
"""
from __future__ import annotations

import numpy as np

from ..registry import ROADS
from ._common import PulseParams, PulseRoad


@ROADS.register("half_sine")
class HalfSine(PulseRoad):
    """Half-sine bump h·sin(π s/L) over a length (m) or a duration (s)."""

    Params = PulseParams

    @staticmethod
    def shape(u):
        return np.sin(np.pi * u)

    @staticmethod
    def shape_rate(u):
        return np.pi * np.cos(np.pi * u)
