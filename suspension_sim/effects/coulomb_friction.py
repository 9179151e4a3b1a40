"""Coulomb (dry) friction in the suspension: F = −F_c·sgn(v), smoothly regularised."""
from __future__ import annotations

import warnings

import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, PerCornerPos, corner_array, reduced_mass
from .base import Effect


class CoulombFrictionParams(Params):
    force: PerCornerNonNeg = Field(100.0, description="friction force level F_c in N (one value, or one per corner)")
    v_eps: PerCornerPos = Field(0.01, description="regularisation velocity in m/s: F = −F_c·tanh(v/v_eps) "
                                "(reaches 96 % of F_c at 2·v_eps)")


@EFFECTS.register("coulomb_friction")
class CoulombFriction(Effect):
    """Dry (Coulomb) friction on the suspension: F = −F_c·tanh(v/v_eps), a smooth sgn(v).

    Force law: ``F = −F_c · tanh(v / v_eps)`` with ``v`` the travel rate (m/s) and ``F_c`` the friction level
    (N; the thesis's ``F``: 1000 N on its 250 kg SDOF rig).  For |v| ≫ v_eps this is ``−F_c·sgn(v)``; near
    v = 0 it is a stiff viscous damper ``F_c/v_eps`` (default v_eps = 0.01 m/s), which stands in for sticking:
    under a net load ``F < F_c`` the suspension creeps at ``v_eps·atanh(F/F_c)`` instead of stopping.

    Why regularised, not MuJoCo-native: the suspension is a tendon between two slide joints, so joint
    ``frictionloss`` does not apply; tendon ``frictionloss`` exists, but its force is a soft constraint whose
    softness depends on ``solref``/``solimp`` and whose force is not one of the plant's logged effect forces
    (see tests/test_effects.py for how it compares).  The regularised law is evaluated explicitly once per
    step; it is stable and accurate while the friction "damping" is small against the step:
    ``F_c/v_eps · dt / m_red ≲ 1`` (m_red = relative body–wheel mass).  A warning names v_eps when it is not.

    Signature in measured data: a force step of 2·F_c at every travel-rate reversal (the residual force vs
    travel rate is a step through the origin, flat on each side); the suspension sticks on small inputs
    (dead band: travel stays still until the road force exceeds F_c, so small-amplitude responses are
    stiff and lightly damped by the tires alone), flat spots in the travel at reversals, harsh body
    acceleration on smooth roads, and energy loss per cycle proportional to amplitude (not to amplitude²).
    """

    Params = CoulombFrictionParams
    target = "suspension"
    signature = ("force step of 2·F_c at travel-rate reversal (residual vs velocity is a step through 0); "
                 "stick/dead band in travel on small inputs; flat spots at reversals")

    def reset(self):
        self.Fc = corner_array(self, "force")
        self.v_eps = corner_array(self, "v_eps")
        gain = self.Fc / self.v_eps * self.ctx.dt / reduced_mass(self.ctx)
        if np.any(gain > 1.0):
            vmin = float(np.max(self.Fc * self.ctx.dt / reduced_mass(self.ctx)))
            warnings.warn(f"coulomb_friction: v_eps is small for dt={self.ctx.dt:g} s (F_c/v_eps·dt/m_red = "
                          f"{float(np.max(gain)):.2g} > 1): the friction force will chatter near zero travel rate; "
                          f"use v_eps >= {vmin:.2g} m/s or a smaller sim.dt", stacklevel=2)

    def force(self, s, v, t, dt):
        return -self.Fc * np.tanh(v / self.v_eps)
