"""The library of candidate missing effects.

Each candidate adds parameters to the calibrated model (their starting values scaled from the data: the
travel, travel-rate and suspension-force levels of the nominal simulation), says whether it can apply to the
record at hand, and writes its fitted parameters as a ``vehicle.effects`` entry (a registered effect of
:mod:`suspension_sim.effects`, so the corrected model simulates in MuJoCo unchanged), as ideal-actuator
parameters (``actuator_delay``/``actuator_lag`` map onto ``actuator.params.delay``/``time_constant``), or as
a changed nominal parameter (``parameter:<name>``).  Every docstring states the physical signature the
effect leaves in data; :func:`library` lists them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import fastsim as fs
from .model import NOMINAL, FreeParam


@dataclass
class Scales:
    """Data-derived magnitudes from the nominal model's simulation on the training data."""

    s: float  # RMS travel (m)
    s_max: float  # max |travel|
    v: float  # RMS travel rate (m/s)
    F: float  # RMS linear suspension force (N)
    k: float  # spring stiffness in use (N/m)
    c: float  # damping in use (N s/m)
    has_force: bool
    tire_tension: bool  # the nominal model predicts a pulling tire somewhere
    m_red: float = np.inf  # mass of the relative motion across the suspension (kg; inf for a damper element)
    h: float = 1e-3  # simulation sub-step (s)


class Candidate:
    """Base class: ``name``, ``applies(kind, scales)``, ``free(scales)`` -> FreeParams, ``starts``."""

    name = ""
    kinds = ("quarter_car", "sdof", "damper", "half_car")

    def applies(self, kind: str, sc: Scales, spec) -> tuple[bool, str]:
        if kind not in self.kinds:
            return False, f"not defined for a {kind}"
        if self.name in spec.effects:
            return False, "already in the model"
        return True, ""

    def free(self, sc: Scales) -> list[FreeParam]:
        return []

    def starts(self, sc: Scales) -> list[list[float]]:
        """Alternative starting values of the candidate's own parameters (multi-start)."""
        return [[f.init for f in self.free(sc)]]

    def setup(self, P: np.ndarray, sc: Scales) -> None:
        """Fixed settings the candidate needs in the parameter vector (e.g. a regularisation)."""

    def describe(self, P: np.ndarray) -> dict:
        """The fitted candidate as a model change: {"effect": {...}} or {"actuator": {...}} or {"param": ...}."""
        raise NotImplementedError

    @property
    def signature(self) -> str:
        doc = (self.__doc__ or "").split("Signature:")
        return " ".join(doc[1].split()) if len(doc) > 1 else ""


class CoulombFriction(Candidate):
    """Dry friction ``F = −F_c·tanh(v/v_eps)`` on the suspension (F_c and the regularisation v_eps fitted; v_eps
    starts at 2 % of the RMS travel rate and stays soft enough for the simulator's explicit sub-step, which
    the candidate refines up to ×4 so that v_eps can get that low).

    Signature: a force step of 2·F_c at every travel-rate reversal (the residual force against travel rate
    is a step through the origin, flat on both sides); sticking and flat spots in travel at reversals;
    relatively more damping on small inputs than on large ones."""

    name = "coulomb_friction"
    max_refine = 4

    def _refine(self, sc):
        """Sub-step refinement so that v_eps can reach 2 % of the RMS travel rate (at most ×4): with the
        record's sub-step alone the stability bound held v_eps at ~7 mm/s in the synthetic matrix (truth
        2 mm/s), which left ~10 % of the error above the noise floor unexplained."""
        v0 = max(sc.F * sc.h / max(sc.m_red, 1e-12), 1e-5)
        return int(min(self.max_refine, max(1, np.ceil(v0 / max(0.02 * sc.v, 1e-12)))))

    def _veps_min(self, sc):
        # soft enough for the explicit sub-step: F_c/v_eps·h/m_red <= 1 for F_c up to the RMS suspension force
        return max(sc.F * sc.h / self._refine(sc) / max(sc.m_red, 1e-12), 1e-5)

    def setup(self, P, sc):
        P[fs.VEPS] = max(0.02 * sc.v, self._veps_min(sc))
        P[fs.SUB] = max(P[fs.SUB], self._refine(sc))

    def free(self, sc):
        # the regularisation v_eps is fitted too (from 2 % of the RMS travel rate), bounded below by stability
        v0 = max(0.02 * sc.v, self._veps_min(sc))
        return [FreeParam("coulomb_friction.force", fs.CF, 0.05 * sc.F, 0.0, np.inf, sc.F),
                FreeParam("coulomb_friction.v_eps", fs.VEPS, v0, self._veps_min(sc), max(0.5 * sc.v, 2 * v0), v0)]

    def describe(self, P):
        return {"effect": {"type": "coulomb_friction", "params": {"force": P[fs.CF], "law": "tanh", "v_eps": P[fs.VEPS]}}}


class QuadraticDamping(Candidate):
    """Orifice damping ``F = −c_v·v·|v|`` added to the linear damper.

    Signature: the residual force against travel rate is an odd parabola through the origin, alike in
    compression and rebound; the extra damping grows with stroke speed, so resonance peaks fall more than
    linearly with the excitation level."""

    name = "quadratic_damping"

    def free(self, sc):
        return [FreeParam("quadratic_damping.c_v", fs.CV, 0.05 * sc.F / max(sc.v ** 2, 1e-12), 0.0, np.inf,
                          sc.F / max(sc.v ** 2, 1e-12))]

    def describe(self, P):
        return {"effect": {"type": "quadratic_damping", "params": {"c_v": P[fs.CV]}}}


class AsymmetricDamping(Candidate):
    """Different damping in compression and rebound: one signed parameter Δc, added to the linear damping
    in rebound when Δc > 0 (``c_reb = Δc``) and in compression when Δc < 0 (``c_comp = −Δc``).

    Signature: the residual force against travel rate has a kink at v = 0 (one slope in compression,
    another in rebound); the mean travel drifts under a symmetric input (jacking / packing down) and the
    travel response is skewed."""

    name = "asymmetric_damping"

    def free(self, sc):
        return [FreeParam("asymmetric_damping.delta_c", fs.CREB, 0.1 * sc.c, -np.inf, np.inf, max(sc.c, 1.0),
                          signed_pair=fs.CCOMP)]

    def starts(self, sc):
        return [[0.1 * sc.c], [-0.1 * sc.c]]

    def describe(self, P):
        return {"effect": {"type": "asymmetric_damping", "params": {"c_comp": P[fs.CCOMP], "c_reb": P[fs.CREB]}}}


class BumpStop(Candidate):
    """Elastic end stops beyond a free travel ±gap: ``F = −k_stop·(|s| − gap)·sgn(s)`` outside it.

    Signature: the residual force against travel is zero inside a band and rises steeply outside it; the
    travel distribution is clipped near ±gap; spikes in body acceleration whenever a stop is hit (large
    inputs only)."""

    name = "bump_stop"

    def free(self, sc):
        return [FreeParam("bump_stop.gap", fs.GAP, 0.7 * sc.s_max, 1e-6 * sc.s_max, np.inf, sc.s_max),
                FreeParam("bump_stop.stiffness", fs.KSTOP, 2 * max(sc.k, sc.F / max(sc.s, 1e-12)), 0.0, np.inf,
                          max(sc.k, sc.F / max(sc.s, 1e-12)))]

    def starts(self, sc):
        k = 2 * max(sc.k, sc.F / max(sc.s, 1e-12))
        return [[f * sc.s_max, k] for f in (0.5, 0.8)]

    def describe(self, P):
        return {"effect": {"type": "bump_stop", "params": {"gap": P[fs.GAP], "stiffness": P[fs.KSTOP]}}}


class CubicStiffness(Candidate):
    """Cubic spring ``F = −k3·s³`` (hardening for k3 > 0, softening for k3 < 0).

    Signature: stiffness that depends on amplitude: the residual force against travel is an odd cubic
    (flat at the origin); the resonance frequency moves with excitation level (Duffing), sine inputs give
    odd harmonics (3f)."""

    name = "cubic_stiffness"

    def free(self, sc):
        k3s = sc.F / max(sc.s ** 3, 1e-30)
        return [FreeParam("cubic_stiffness.k3", fs.K3, 0.0, -np.inf, np.inf, k3s)]

    def describe(self, P):
        return {"effect": {"type": "cubic_stiffness", "params": {"k3": P[fs.K3]}}}


class TireLiftoff(Candidate):
    """The tire pushes but never pulls: total tire force ``max(0, F_static − k_t·x − c_t·ẋ)`` (no parameter;
    only the nominal parameters are refitted).

    Signature: the dynamic tire load is clipped at −(static load); the wheel flies (wheel acceleration near
    −g plus the suspension force share) and lands with impacts; only on large inputs near the wheel-hop
    frequency.  Applies only when the nominal model predicts a pulling tire somewhere."""

    name = "tire_liftoff"
    kinds = ("quarter_car", "half_car")

    def applies(self, kind, sc, spec):
        ok, why = super().applies(kind, sc, spec)
        if ok and not sc.tire_tension:
            return False, "the calibrated model never predicts a pulling tire"
        return ok, why

    def setup(self, P, sc):
        P[fs.LIFT] = 1.0

    def describe(self, P):
        return {"effect": {"type": "tire_liftoff", "params": {}}}


class ActuatorDelay(Candidate):
    """A pure delay ``d`` between the measured force command and the force (ideal actuator ``delay``).

    Signature: the residual is largest where the force command changes fast; its coherence with the force
    input rises with frequency and the phase of the output relative to the input lags linearly with
    frequency (−360°·f·d)."""

    name = "actuator_delay"
    kinds = ("quarter_car", "sdof", "half_car")

    def applies(self, kind, sc, spec):
        ok, why = super().applies(kind, sc, spec)
        if ok and not sc.has_force:
            return False, "no force input measured"
        return ok, why

    def free(self, sc):
        return [FreeParam("actuator_delay.delay", fs.DELAY, 0.005, 0.0, 0.5, 0.01)]

    def starts(self, sc):
        return [[0.002], [0.015]]

    def describe(self, P):
        return {"actuator": {"delay": P[fs.DELAY]}}


class ActuatorLag(ActuatorDelay):
    """A first-order lag ``τ·Ḟ = u − F`` between the force command and the force (ideal actuator
    ``time_constant``).

    Signature: residual coherent with the force input above the corner frequency 1/(2πτ); the force
    transmitted at high frequency is attenuated and phase-shifted (−45° at the corner)."""

    name = "actuator_lag"

    def free(self, sc):
        return [FreeParam("actuator_lag.time_constant", fs.TAU, 0.005, 1e-5, 1.0, 0.01)]

    def starts(self, sc):
        return [[0.003], [0.02]]

    def describe(self, P):
        return {"actuator": {"time_constant": P[fs.TAU]}}


class Hysteresis(Candidate):
    """Bouc–Wen hysteresis ``F = −F_h·w``, ``dw/ds = (1 − |w|·(1 + sgn(ṡ·w))/2)/x_y`` (β = γ = ½, n = 1):
    a rate-independent element that is stiff (F_h/x_y) on reversal and saturates at ±F_h.

    Signature: the residual force against travel forms a loop whose area does not depend on the travel
    rate (rate-independent energy loss per cycle), with rounded corners of width ~x_y after each reversal
    (unlike Coulomb friction, which switches at once with the velocity sign)."""

    name = "hysteresis"

    def free(self, sc):
        return [FreeParam("hysteresis.force", fs.BWF, 0.05 * sc.F, 0.0, np.inf, sc.F),
                FreeParam("hysteresis.x_y", fs.BWX, 0.2 * sc.s, 1e-3 * sc.s, np.inf, sc.s)]

    def starts(self, sc):
        return [[0.05 * sc.F, 0.2 * sc.s]]

    def describe(self, P):
        return {"effect": {"type": "hysteresis", "params": {"force": P[fs.BWF], "x_y": P[fs.BWX]}}}


class Backlash(Candidate):
    """A spring ``k_b`` connected through a play of ±b (play operator): ``F = −k_b·y`` with ``y`` following the
    travel at a lag of ``b`` and staying put while the play is taken up.

    Signature: the residual force against travel is a parallelogram: after each reversal the force stays
    flat for 2·b of travel, then follows with stiffness k_b; a dead band of free motion at every
    reversal."""

    name = "backlash"

    def free(self, sc):
        kb = max(sc.k, sc.F / max(sc.s, 1e-12))
        return [FreeParam("backlash.stiffness", fs.BLK, 0.2 * kb, 0.0, np.inf, kb),
                FreeParam("backlash.play", fs.BLB, 0.1 * sc.s, 0.0, np.inf, sc.s)]

    def starts(self, sc):
        kb = max(sc.k, sc.F / max(sc.s, 1e-12))
        return [[0.2 * kb, 0.2 * sc.s]]

    def describe(self, P):
        return {"effect": {"type": "backlash", "params": {"stiffness": P[fs.BLK], "play": P[fs.BLB]}}}


class WrongParameter(Candidate):
    """A nominal parameter that the model states as known is wrong (``parameter:<name>``): it is freed and
    refitted.

    Signature: a mis-set mass or stiffness shifts a resonance (residual PSD peaks at the resonance, with
    a dispersive shape), a mis-set damping changes its height; the residual force is linear in
    acceleration, travel or travel rate respectively."""

    def __init__(self, pname: str, kind: str):
        self.pname = pname
        self.name = f"parameter:{pname}"
        self.slot = NOMINAL[kind][pname]

    def applies(self, kind, sc, spec):
        if self.pname not in spec.fixed_nominal:
            return False, "already calibrated (free)"
        return True, ""

    def free(self, sc):
        return []

    def free_for(self, P):
        v = P[self.slot]
        from .model import POSITIVE

        return [FreeParam(self.pname, self.slot, v, 1e-6 * abs(v) if self.pname in POSITIVE else 0.0, np.inf,
                          max(abs(v), 1e-9))]

    def describe(self, P):
        return {"param": {self.pname: P[self.slot]}}


def library(kind: str) -> list[Candidate]:
    """Every candidate for a model kind (parameter candidates for each nominal parameter)."""
    libs = [CoulombFriction(), QuadraticDamping(), AsymmetricDamping(), BumpStop(), CubicStiffness(),
            TireLiftoff(), ActuatorDelay(), ActuatorLag(), Hysteresis(), Backlash()]
    libs += [WrongParameter(p, kind) for p in NOMINAL[kind]]
    return libs


NAMES = ["coulomb_friction", "quadratic_damping", "asymmetric_damping", "bump_stop", "cubic_stiffness",
         "tire_liftoff", "actuator_delay", "actuator_lag", "hysteresis", "backlash"]
