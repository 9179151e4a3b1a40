"""Bump (1 − cos): a smooth single (or repeated) bump or dip, given in space or in time.

Shape over one bump of length L (or duration T) starting at s0, with s = x (spatial) or t (temporal)::

    z(s) = (h/2)·(1 − cos(2π (s − s0)/L))   for s0 ≤ s ≤ s0 + L,   0 otherwise

so the peak h is reached in the middle, and height and slope are continuous at both ends.

Presets (``preset:``; explicitly given fields override them):

- ``lin_kanellakopoulos``: Lin & Kanellakopoulos (IFAC 1996), Eq. (24):
  r(t) = a(1 − cos 8πt) for 0.5 ≤ t ≤ 0.75 s, 0 otherwise, with a = 0.04 m (their "height of the bump is
  equal to 8 cm").  Since 8π·0.5 = 4π, this is exactly our temporal bump with ``start`` 0.5 s,
  ``duration`` 0.25 s and ``height`` 2a = 0.08 m (a full cosine period of 4 Hz).  Reproduced exactly.
- ``fallah``: Fallah, Sorniotti & Gruber drive over "a bump at 35 km/h" in IPG CarMaker but do not give
  its size.  Chosen here: a spatial 1 − cos bump 5 m long and 0.10 m high starting 5 m after the start
  line (a size commonly used for bump tests in the active-suspension literature).  Set the speed in the
  scenario: ``road.speed: 9.7222`` (35 km/h); at that speed the bump lasts 0.51 s (≈ 1.9 Hz).

A spatial bump is met by each axle when that axle's distance reaches ``start`` (the rear wheels later, also
under a varying speed); a temporal bump reaches the rear wheels after the front-to-rear travel time.
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from ..registry import ROADS
from ._common import PulseParams, PulseRoad

PRESETS = {
    "lin_kanellakopoulos": {"height": 0.08, "duration": 0.25, "start": 0.5},
    "fallah": {"height": 0.10, "length": 5.0, "start": 5.0},
}


class BumpParams(PulseParams):
    preset: Optional[Literal["lin_kanellakopoulos", "fallah"]] = Field(
        None, description="a paper's bump (see the module docstring); given fields override it")

    @model_validator(mode="before")
    @classmethod
    def _preset(cls, data):
        if isinstance(data, dict) and data.get("preset") in PRESETS:
            base = dict(PRESETS[data["preset"]])
            # a user-given length replaces a preset duration and vice versa
            if "length" in data:
                base.pop("duration", None)
            if "duration" in data:
                base.pop("length", None)
            data = {**base, **data}
        return data


@ROADS.register("bump")
class Bump(PulseRoad):
    """Bump (1 − cos) of height h over a length (m) or a duration (s); presets for Lin & Kanellakopoulos and Fallah."""

    Params = BumpParams

    @staticmethod
    def shape(u):
        return 0.5 * (1.0 - np.cos(2.0 * np.pi * u))

    @staticmethod
    def shape_rate(u):
        return np.pi * np.sin(2.0 * np.pi * u)
