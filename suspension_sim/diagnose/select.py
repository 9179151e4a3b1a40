"""Selection of missing effects: a forward search with a beam over pairs, guarded against worse and absurd
models.

1. Calibrate the nominal model's free parameters on the training part.
2. For every applicable candidate (:func:`.candidates.library`): add it, refit (the candidate's parameters
   and every free parameter, from several starts), and score it on the training data by BIC.
3. A candidate is *kept* only if, on held-out data, it lowers the error beyond the noise: (a) its BIC is
   below the current model's; (b) the held-out improvement is significant (z > 2 over 20 contiguous blocks,
   or at least half of the held-out error above the noise floor removed); (c) it removes at least
   ``min_excess_drop`` (10 %) of the held-out error above the floor; (d) the held-out NRMSE falls by at
   least ``min_rel_drop`` (5 %); (e) **no output channel's held-out error rises by more than its noise
   floor** (a change that trades one channel for another is not a better model); (f) **its size is
   distinguishable from zero** (a single size parameter, e.g. a friction force, beyond 2 standard errors of
   zero; several together by their joint covariance, :func:`size_zero`); the parameters stay within their
   physical bounds by construction (the fit is bounded); (g) **the sensor-zero rule**: a freed parameter that
   moves the static sag (a mass: :func:`sag_params`), with position sensors zeroed at the nominal ride height,
   is kept only when it beats the rival explanation, the same model with a free offset on each position
   channel (the parameter at its stated value), by BIC on the training window (the rival pays ``log n`` per
   offset).  A travel sensor zeroed 3 mm off the ride height was read as sag: a mass 19 kg light took the travel
   while making both accelerations worse, each by less than one floor (blind battery null_van_travel_zero).
   When the rival has the lowest BIC of the round and passes the gates (a)–(e), it is adopted (the position
   sensors get free offsets, no effect is named, the search goes on) and the report says how far their zero is
   from the ride height.  **The joint explanation**: a sag-moving candidate is also fitted with the
   positions read from the model's own equilibrium (``position_zero: own``: each parameter set's rest positions
   subtracted, :meth:`.Problem.rest`; the mass changed *and* the sensors zeroed where the car settled, or the
   car re-levelled), and the lower training BIC of its plain and own-zero fits is the one judged (the same
   parameters; the own zero only when its implied offsets are distinguishable from zero, :meth:`_offsets_zero`).
   A car 14 % heavier with no sag in its travel (diagnose_matrix's parameter:sprung_mass) had its plain mass
   rejected as zero-size, and a stiffness with a tire damping stood in for it; with its own zero the mass
   wins by ~10⁴ and is named, and the report says the positions appear measured from the car's own
   equilibrium.  (Free offsets instead of the own zero let an unsprung mass take a missing cubic spring's
   static signature: blind battery two_heavier_cubic.)  Pairs and exchanges with a mass go through the same
   fit (an exchange's sag-moving newcomer also meets the rival: the model it joins, the effect taken out,
   with free position offsets).
   (h) **the sensor-gain rule**: a kept candidate that frees a vehicle parameter (:class:`ParameterCandidate`) is
   kept only when it beats the rival explanation, the current model with a free gain on every output channel
   (the parameter at its stated value), by training BIC.  The gains are eliminated in closed form per channel
   with the offsets (a line through simulated against measured, :meth:`.Problem.fit_gains`) and pay ``log n``
   each, as the offsets do.  The measured inputs (road, force) are the reference: a gain common to every output
   is identifiable against the stated vehicle, but it is the same as the road (or force) input reading off by
   its reciprocal, and the report says the gains are relative to the inputs.  A wheel accelerometer reading 4 %
   low was taken up by the tire stiffness (235 → 232.2 kN/m) and named beside the true cubic spring (blind
   battery cubic_sedan_scale_bias).  When the rival has the lowest BIC and passes the gates it is adopted (the
   gains stay free, no parameter is named, the search goes on) and the verdict reports each channel whose gain
   is off 1 by more than 2 standard errors and its noise floor ("wheel_acc reads 3.9 % low").  When no candidate
   is kept while the model is still above ``near`` × the floor, the gains are also tried alone (the remainder
   of a gain error no parameter stands in for), by the same gates, and adopted only when they bring the model
   within ``near`` × the floor (else they would stand in for model error).  Only where a road or base displacement is
   measured (:meth:`Selector.gains_identifiable`): driven by a force alone (a shaker rig, a damper rig), scaling
   every mass, stiffness and damping scales every output, and a gain is the scale of the free parameters.
4. The kept candidate with the lowest BIC is added, and the search repeats (up to ``max_effects``).
5. **Beam over pairs**: when no single candidate is kept while the held-out error is still more than
   ``far`` (3) times the noise floor, the ``beam`` (4) candidates with the best training cost are tried
   in pairs (two interacting effects, e.g. friction with bump stops, can each fail alone).  Members must
   have lowered the training BIC alone, and a pair at least one member that alone lowered the held-out
   error (EMPS: the encoder's floor is tiny, so pairs were always tried, and every single of round 2 made
   the PULSES test worse: 6 pairs, most of a 25–34 min run, none kept).
6. Exchange: when the forward search stops (nothing kept, or ``max_effects`` reached) while the held-out
   error is still more than ``near`` (1.5) times the floor, each effect of the model is replaced in turn by
   each of the ``beam`` best single candidates of round 1 (:meth:`Selector._exchange_pool`), and a
   replacement that passes the same gate against the current model is made (at most ``max_swaps`` (2); the
   forward search then goes on when there is room).  The forward search is greedy: an effect added early can
   stand in for one that only shows once another is in (blind battery two_asym_cubic: a bump stop stood in
   for the cubic spring while the asymmetric damping was missing, and nothing beside the two improved on them).
7. Backward check: an added effect is dropped again when the model refitted without it is not worse by BIC
   and within ``min_rel_drop`` on held-out data.
8. When the final held-out error is still far above the floor, the report says so: "unexplained: N× the
   noise floor".

Speed: when the training part is longer than ``LONG`` (30 000 samples: 30 s at 1 kHz; or 1.5 ×
``screen_samples`` if that is more), the screening fits use its first ``screen_samples`` samples (default
8 000) and the chosen candidate is refitted on the whole training part.  A screened candidate is judged
against the current model refitted on the same window (a model fitted on 8 000 samples is worse on held-out
data than one fitted on 65 000, by more than a second effect's gain on the Silverbox: 0.0076 against 0.0066
held-out NRMSE there), and the chosen one is judged again, refitted on the whole training part, against the
current whole-part model by the same gate (when it fails there, the next kept candidate is tried).  The screening window is doubled
until every input and output channel's RMS in it is at least half its RMS over the training part (an effect
that depends on amplitude is screened at the record's level: a record whose excitation grows is screened on
more of it).  Candidates of a round are fitted side by side in threads (:meth:`Selector.run`).  A round after
the first is not fitted when the model so far is already at the noise floor on held-out data (its
screening-window fit, which every trial of the round is judged against): gate (c) needs an error above the
floor to remove, so no single candidate or pair could be kept, and the round's fits decided nothing (the
speed benchmark's round 2 after the friction: 8 fits at a 2× finer step, about half of the CPU time).  Round 1
is always fitted: its trials are each candidate's evidence against the calibrated nominal model (the report
lists them; the exchange draws from them).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import welch

from .calibrate import FitResult, Problem, fit, sensor_reading
from .candidates import Candidate, ParameterCandidate, Scales, library
from .io import Record
from .model import ModelSpec, is_position


def noise_floor(y: np.ndarray, fs_hz: float) -> float:
    """Sensor-noise standard deviation estimated from the data: the median PSD level in the top band
    (60–95 % of Nyquist), where the dynamics have rolled off, taken as white over the whole band."""
    n = len(y)
    nper = min(n, 1024)
    f, p = welch(y - np.mean(y), fs=fs_hz, nperseg=nper)
    band = (f > 0.6 * fs_hz / 2) & (f < 0.95 * fs_hz / 2)
    if not band.any():
        return 0.0
    # the median of a Welch PSD of K segments is chi-square with ~2K degrees of freedom (Hann, 50 % overlap:
    # 2K / 1.056), whose median lies below its mean: without this a 2 800-sample residual (the half car's
    # training part) read white noise 4 % low, a 7 000-sample one 1.6 %
    K = max(1, (n - nper) // (nper // 2) + 1)
    nu = 2.0 * K / (1.0 + 2.0 * 0.167 ** 2) if K > 1 else 2.0
    from scipy.stats import chi2

    return float(np.sqrt(np.median(p[band]) / (chi2.median(nu) / nu) * fs_hz / 2))


def difference_floor(y: np.ndarray) -> float:
    """Sensor-noise standard deviation from the second differences of the record, robustly: 1.4826·MAD of
    Δ²y over √6 (white noise of std σ gives Δ²y of std √6·σ).  The second difference removes what is smooth
    at the sample rate (1 kHz records of 1–20 Hz dynamics: a 10 Hz component keeps 0.4 % of its amplitude),
    and the median ignores what is sharp but rare: the force step of dry friction at each travel-rate
    reversal (a few samples per reversal) lifts the top band of a friction record's body acceleration, which
    holds the step's broadband spectrum, to 1.96–2.41× its noise (the matrix's coulomb_friction and
    two:coulomb+cubic records), while this reads 1.03–1.07×.  Where the record itself is rough at the sample
    rate (the Silverbox's multisine, up to 0.7 of Nyquist: 11 mV against a top band of 0.07 mV) it reads
    high; :meth:`Selector.floors` takes the lower of the two.  0 when the median is 0 (a quantised encoder
    standing still)."""
    d = np.diff(np.asarray(y, float), 2)
    if len(d) < 16:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(6.0))


def record_floor(y: np.ndarray, fs_hz: float) -> tuple[float, float, float]:
    """(floor, top-band estimate, second-difference estimate) of one channel: the lower of
    :func:`noise_floor` and :func:`difference_floor` (each reads high where the record holds what it does not
    remove: broadband sparse steps for the first, content near Nyquist for the second; both read white noise
    within a few per cent), the top band alone when the difference estimate is 0."""
    top = noise_floor(y, fs_hz)
    dif = difference_floor(y)
    return (min(top, dif) if dif > 0 else top), top, dif


NOISE_LIKE = 0.2  # a residual with at most this share of its power predictable (inputs, other channels) is noise


def _cross_spectra(X: np.ndarray, nper: int):
    """Cross-spectral matrices S[f, i, j] of the columns of X (Welch: Hann, 50 % overlap, mean removed) and the
    number K of segments averaged."""
    nper = int(min(nper, len(X)))
    w = np.hanning(nper)
    F = np.stack([np.fft.rfft((X[s:s + nper] - X[s:s + nper].mean(axis=0)) * w[:, None], axis=0)
                  for s in range(0, len(X) - nper + 1, nper // 2)])
    return np.einsum("kfi,kfj->fij", F, F.conj()) / len(F), len(F)


MIN_SEGMENTS = 12  # Welch segments the conditioned spectra average at least (the (K − p)/K correction needs K ≫ p)


def segment_length(n: int) -> int:
    """Welch segment length for the conditioned spectra of ``n`` samples: the longest power of two (at least
    256) that still gives :data:`MIN_SEGMENTS` half-overlapping segments.  Long segments resolve the slow
    dynamics: with 256 samples at 1 kHz (3.9 Hz bins) a missing stop's error at the ~1 Hz body mode falls in
    the lowest bins, where the per-segment mean removal and the window smear it, and read as unpredictable
    (a quarter car's travel residual 13× its noise was taken for coloured noise, 16 % predictable; with 1024
    samples 85 %), while noise stays unpredictable at any length."""
    nper = 256
    while 2 * n / (2 * nper) >= MIN_SEGMENTS + 1:
        nper *= 2
    return int(min(nper, n))


PREDICTABLE_BAND = 0.5  # a frequency bin whose residual is more than this share predictable holds model error


def incoherent_noise(resid: np.ndarray, inputs: np.ndarray | None = None, nper: int | None = None,
                     exclude: float | None = PREDICTABLE_BAND) -> list:
    """Per residual channel: (std of the part of the residual that no linear filter of the inputs and of the
    other channels' residuals predicts, share of its power that they do predict).

    Sensor noise is independent between channels and of the inputs, whatever its colour.  A force missing
    from the model shows in every channel's residual through the same dynamics (and is driven by the
    inputs), so it is predictable from them (spectra over segments of :func:`segment_length`).  Per
    frequency, the conditioned spectrum
    S_ii − S_io·S_oo⁻¹·S_oi is what no linear filter of the others predicts; with K segments and p
    predictors its expectation for pure noise is (K − p)/K of the truth, which is corrected.

    ``exclude``: the bins where more than this share of the residual is predictable hold model error, and
    the part of it that the finite number of segments leaves unexplained (a few per cent of a large error)
    would pass as noise; there the noise spectrum is interpolated (over log frequency) from the bins where
    the residual is unpredictable, never above the conditioned spectrum itself.  (A heavier car's nominal
    residual, 18× its white noise in body acceleration and travel: the whole-band unpredictable part reads
    3.1× and 4.1× the noise, the one outside the predictable bands 0.97× and 1.01×.)  None: whole band.
    The second number of each pair, the predictable share, is always over the whole band."""
    R = np.asarray(resid, float)
    cols = [R] + ([np.asarray(inputs, float).reshape(len(R), -1)] if inputs is not None and np.size(inputs) else [])
    X = np.column_stack(cols)
    X = X[:, [j for j in range(X.shape[1]) if j < R.shape[1] or np.std(X[:, j]) > 0]]
    S, K = _cross_spectra(X, segment_length(len(X)) if nper is None else nper)
    out = []
    for i in range(R.shape[1]):
        o = [j for j in range(X.shape[1]) if j != i and np.std(X[:, j]) > 0]
        Sii = S[:, i, i].real
        pred = np.zeros_like(Sii)
        if o:
            Soo, Sio = S[:, o][:, :, o], S[:, i, o]
            try:
                pred = np.einsum("fo,fo->f", Sio, np.linalg.solve(Soo, Sio.conj()[..., None])[..., 0]).real
            except np.linalg.LinAlgError:
                pass
        cond = np.maximum(Sii - pred, 0.0) * K / max(K - len(o), 1)
        share = min(float(np.sum(cond)) / max(float(np.sum(Sii)), 1e-300), 1.0)
        noise = cond
        if exclude is not None and o:
            q = pred / np.maximum(Sii, 1e-300)
            m = q <= exclude
            m[0] = False  # the mean is removed per segment
            if m.sum() >= 3 and (~m[1:]).any():
                lf = np.log(np.arange(len(Sii)) + 0.5)
                noise = np.where(m, cond, np.minimum(cond, np.interp(lf, lf[m], cond[m])))
            # the DC bin (what the per-segment mean removal leaves of the slowest content) is in neither sum
            nshare = min(float(np.sum(noise[1:])) / max(float(np.sum(Sii[1:])), 1e-300), 1.0)
        else:
            nshare = share
        out.append((float(np.sqrt(nshare * np.var(R[:, i]))), 1.0 - share))
    return out


def spectral_z(e_before: np.ndarray, e_after: np.ndarray) -> float:
    """Significance of a held-out improvement against what the noise alone gives, with the residual's own
    spectrum (not a count of samples or blocks).

    With Δ = e_after − e_before (the candidate's change of the simulated outputs, fitted on other data) and
    held-out residuals e_before = n (no real effect: noise n, whatever its colour), the improvement
    I = Σ e_before² − Σ e_after² = −2⟨n, Δ⟩ − ‖Δ‖² has mean −‖Δ‖² and standard deviation 2·√Var⟨n, Δ⟩,
    Var⟨n, Δ⟩ = ∫ S_n(f)·|Δ(f)|² df (per channel, channels independent).  S_n is read from the residual
    after the candidate (Welch), which holds any model error left as well: conservative.  Returns
    z = I / (2·√Var⟨n, Δ⟩).  An effect that acts on a few samples (a stop touched a few times) concentrates Δ
    there: the block z test (20 contiguous blocks) cannot exceed about √(blocks it acts in), while this
    one weighs the improvement against the noise in exactly those samples."""
    from scipy.signal import welch

    eb = np.asarray(e_before, float).reshape(len(e_before), -1)
    ea = np.asarray(e_after, float).reshape(len(e_after), -1)
    n = len(eb)
    if n < 16:
        return float("nan")
    gain = float(np.sum(eb ** 2 - ea ** 2))
    var = 0.0
    M = 2 * n
    fk = np.arange(M // 2 + 1) / M
    for j in range(eb.shape[1]):
        D = ea[:, j] - eb[:, j]
        if not np.any(D):
            continue
        f, p1 = welch(ea[:, j] - ea[:, j].mean(), fs=1.0, nperseg=min(n, segment_length(n)))
        Dk = np.fft.rfft(D, M)
        var += float(np.sum(np.interp(fk, f, p1) * np.abs(Dk) ** 2)) / M
    if not var > 0:
        return float("inf") if gain > 0 else 0.0
    return gain / (2.0 * np.sqrt(var))


ZERO_Z = 2.0  # a size within this many standard errors of zero is indistinguishable from it


def size_zero(fr: FitResult, members: list) -> bool:
    """Whether an effect's sizes ``members`` [(name, reference)] are together indistinguishable from their
    references (zero for an effect's size, the stated value for a freed nominal parameter): one size within
    ``ZERO_Z`` standard errors; several by the Wald statistic dᵀ·C⁻¹·d of their joint covariance C (Gauss–Newton)
    below the χ² quantile of the same level (4.0 for one size).  One size at a time called an effect zero when
    its sizes are each uncertain along a direction the model cannot see but not together: asymmetric damping
    beside a free linear damping (c + c_comp and c + c_reb are what the record shows; moving all three by the
    same amount changes nothing, so each of c_comp, c_reb has a huge error while their difference, the
    asymmetry, is sharp: blind battery two_asym_cubic, c_comp 1273 / c_reb 2905 N·s/m "indistinguishable
    from zero" in round 1 with ΔBIC −4287)."""
    d = np.array([fr.params[n] - ref for n, ref in members], float)
    sd = np.array([fr.std.get(n, np.inf) for n, _ in members], float)
    single = [not (abs(di) > ZERO_Z * si) for di, si in zip(d, sd)]
    if len(members) == 1 or not all(single):
        return all(single)
    names = [f.name for f in fr.spec.free]
    if fr.corr is None or any(n not in names for n, _ in members) or not np.all(np.isfinite(sd)):
        return True
    idx = [names.index(n) for n, _ in members]
    R = np.asarray(fr.corr, float)[np.ix_(idx, idx)]
    if not np.all(np.isfinite(R)) or not np.all(sd > 0):
        return True
    C = R * np.outer(sd, sd)
    from scipy.stats import chi2

    w = float(d @ np.linalg.pinv(C) @ d)
    return not w > chi2.ppf(chi2.cdf(ZERO_Z ** 2, 1), len(members))


NOT_SEPARABLE = "not separable on this record"
RHO_SEPARABLE = 0.95  # two parameters whose estimates correlate more than this are not separable (collinear)
LONG = 30000  # a training part longer than this (samples) is screened on part of it
# a placement (full car: an axle, a corner) is fitted only when its parent lowered the training BIC by more than
# this (very strong evidence on Kass and Raftery's scale, 2·ln BF > 10) and its size is distinguishable from zero:
# tire lift-off (no size, nothing lifts off) lowered it by −0.0 and asymmetric damping of zero size by −12 on the
# full car's speed record, and each set off 6–8 placement fits of nothing
PLACEMENT_BIC = 10.0


def placement_refused(parent: "Trial | None") -> str:
    """Why a placement is not fitted after its parent's trial in the same round ("" when it is: the parent was
    fitted, lowered the training BIC by more than :data:`PLACEMENT_BIC`, and its size is distinguishable from
    zero)."""
    if parent is None or not parent.applicable or not np.isfinite(parent.d_bic):
        return "was not fitted"
    if parent.zero_size:
        return "has a size indistinguishable from zero"
    if not parent.d_bic < -PLACEMENT_BIC:
        return f"did not lower the training BIC by more than {PLACEMENT_BIC:g} (ΔBIC {parent.d_bic:+.1f})"
    return ""


def sag_params(kind: str) -> set:
    """The parameters of a model kind that move its static sag where position sensors zeroed at the nominal ride
    height see it: the masses (:func:`suspension_sim.vehicles.base.mass_params` less the inertias, which carry no
    weight).  A changed stiffness keeps the static preload (the engine re-levels it: the same ride height), so
    it does not move the sag."""
    if kind == "damper":
        return set()
    from ..registry import VEHICLES
    from ..vehicles.base import mass_params

    return {n for n in mass_params(VEHICLES.get(kind)) if "inertia" not in n}


def default_workers() -> int:
    """Threads that fit candidates side by side: the cores this process may use (at most 4)."""
    import os

    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        n = os.cpu_count() or 1
    return max(1, min(4, n))


@dataclass
class Trial:
    name: str
    round: int
    applicable: bool
    reason: str = ""
    params: dict = field(default_factory=dict)
    bic: float = np.nan
    aic: float = np.nan
    d_bic: float = np.nan
    test_before: float = np.nan
    test_after: float = np.nan
    excess_before: float = np.nan
    excess_after: float = np.nan
    z: float = np.nan
    z_spectral: float = np.nan  # the held-out gain against the noise in the residual's spectrum (spectral_z)
    kept: bool = False
    seconds: float = 0.0
    replaces: list = field(default_factory=list)  # earlier fitted physics this candidate drove to zero (_replaced)
    screened: dict | None = None  # the evidence on the screening window, when the trial was judged again on the whole
    zero_size: bool = False  # every size of the effect indistinguishable from zero (gate (f))
    # the joint fit (rule (g)): the free position offsets of the variant judged, when the candidate fitted beside
    # them beat its plain fit by training BIC (the positions read from the car's own equilibrium), with both BICs
    own_zero: dict | None = None

    def as_dict(self):
        return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in self.__dict__.items()}


@dataclass
class Diagnosis:
    record: Record
    prob: Problem
    test_prob: Problem | None
    train: tuple[int, int]
    test: tuple[int, int]
    floors: dict
    nominal: FitResult
    final: FitResult
    added: list  # [(Candidate, FitResult at its addition, Trial)]
    trials: list
    scales: Scales
    timings: dict = field(default_factory=dict)

    unexplained: float | None = None  # final held-out error / noise floor when far above it
    proposal: dict | None = None  # a law beyond the library (sparse fit to the residual force)
    sensor_zero: dict | None = None  # the position sensors' zero, when the sensor-zero rule (g) adopted it
    # the positions read from the car's own equilibrium: a sag-moving parameter named jointly with free position
    # offsets (rule (g), the joint explanation), with the offsets
    own_equilibrium: dict | None = None
    sensor_gain: dict | None = None  # the output channels' gains, when the sensor-gain rule (h) adopted them
    split: dict | None = None  # how the record was split (split.choose: by events or the default end piece)

    def sims(self, fitres: FitResult):
        """(train/whole-record simulation, test simulation) of a fit, with its fitted channel offsets."""
        s = sensor_reading(fitres, fitres.simulated(self.prob))
        st = sensor_reading(fitres, fitres.simulated(self.test_prob)) if self.test_prob is not None else s
        return s, st

    def nrmse(self, fitres: FitResult) -> dict:
        s, st = self.sims(fitres)
        tp = self.test_prob or self.prob
        z = np.zeros(len(self.prob.channels))
        return {"train": self.prob.nrmse(s, *self.train, offsets=z), "test": tp.nrmse(st, *self.test, offsets=z)}

    def rmse(self, fitres: FitResult) -> dict:
        s, st = self.sims(fitres)
        tp = self.test_prob or self.prob
        z = np.zeros(len(self.prob.channels))
        return {"train": self.prob.rmse(s, *self.train, offsets=z), "test": tp.rmse(st, *self.test, offsets=z)}



def _scales(prob: Problem, spec: ModelSpec, P: dict, b: int, a: int = 0) -> Scales:
    """RMS travel, rate and linear suspension force of the nominal simulation (pooled over corners), and the
    largest travel overall, in compression and in extension, on the training part [a, b) (simulated from the
    record's start: a held-out start piece, split.py, is not in the scales)."""
    kind = prob.kind
    if kind == "damper":
        s = prob.inputs["disp"][a:b]
        v = prob.inputs["vel"][a:b] if "vel" in prob.inputs else np.gradient(s, prob.dt)
        k, c = P.get("spring_stiffness", 0.0), P.get("damping", 0.0)
    else:
        eng = prob.engine(spec)
        out = eng.run([P], b, [(e.label, e.type, e.corners, e.fixed) for e in spec.effects])[0][a:]
        if kind == "sdof":
            base = prob.inputs.get("base", np.zeros(b))[a:b]
            s = out[:, eng.channels.index("pos")] - base
        else:
            s = np.concatenate([out[:, j] - out[:, j].mean() for j, c in enumerate(eng.channels)
                                if c.startswith("susp_travel")])
        v = np.gradient(s, prob.dt)
        ks = [P[n] for n in P if n.startswith("spring_stiffness")]
        cs = [P[n] for n in P if n.startswith("damping")]
        k, c = (float(np.mean(ks)) if ks else 0.0), (float(np.mean(cs)) if cs else 0.0)
    F = k * s + c * v
    Fr = float(np.sqrt(np.mean(F ** 2)))
    if Fr <= 0 and prob.has_force:
        Fr = float(np.std(np.concatenate([v_ for n, v_ in prob.inputs.items() if n.startswith("force")])))
    has_tire = kind not in ("sdof", "damper")
    s_max = float(np.max(np.abs(s))) or 1e-6
    return Scales(float(np.sqrt(np.mean(s ** 2))) or 1e-6, s_max,
                  float(np.sqrt(np.mean(v ** 2))) or 1e-6, Fr or 1.0, k, c, prob.has_force, has_tire,
                  s_comp=max(float(np.max(-s)), 1e-3 * s_max), s_ext=max(float(np.max(s)), 1e-3 * s_max))


def _with_fit(spec: ModelSpec, fr: FitResult) -> ModelSpec:
    """``spec`` with its parameters and starting values at a fit's optimum."""
    s = spec.copy()
    s.P = dict(fr.P)
    for f in s.free:
        if f.name in fr.P:
            f.init = float(fr.P[f.name])
    return s


class Selector:
    spectral_gate = False  # the spectral z decides too (off: the matrix's two:coulomb+cubic then named a
    # stand-in bump stop beside the true pair in both seeds; with the block test alone it names the pair)
    skip_at_floor = True  # a round after the first is not fitted at the floor (module docstring, "Speed")
    sensor_zero_rule = True  # rule (g) of the module docstring (off: the baseline of its test)
    sensor_gain_rule = True  # rule (h) of the module docstring: the sensor-gain rival (off: the baseline of its test)
    joint_zero = True  # rule (g)'s joint explanation: a sag-moving candidate also fitted with its own zero
    joint_model = True  # ... and any candidate joining a model with a mass the search freed (_joint_applies)
    joint_settles = True  # ... that moves where that model settles (_moves_rest; off: every joining candidate)
    event_split = True  # the held-out part holds the record's rare events (split.py; off: always the last part)
    split_info = None  # split.choose's finding (None: a separate test record, or event_split off)
    def __init__(self, rec: Record, spec: ModelSpec, split: float = 0.7, test_record: Record | None = None,
                 floors: dict | None = None, candidates: list[str] | None = None, max_effects: int = 3,
                 screen_samples: int = 8000, min_excess_drop: float = 0.10, z_min: float = 2.0,
                 min_rel_drop: float = 0.05, test_skip: int | None = None, log=None, workers: int | None = None,
                 max_dt: float = 5e-4, beam: int = 4, far: float = 3.0, placements: bool = True,
                 near: float = 1.5, max_swaps: int = 2):
        self.rec = rec
        self.spec = spec
        if rec.kind == "sdof":
            init_sdof(rec, spec)
        self.prob = Problem(rec, spec, max_dt=max_dt)
        n = len(rec)
        if test_record is not None:
            self.train = (0, n)
            self.test_prob = Problem(test_record, spec, skip=50 if test_skip is None else test_skip, max_dt=max_dt)
            self.test = (0, len(test_record))
        else:
            if not 0.05 < split < 0.95:
                raise ValueError("split must be between 0.05 and 0.95")
            b = int(round(split * n))
            self.train, self.test = (0, b), (b, n)
            self.test_prob = None
            if self.event_split:
                # the held-out part must hold the record's rare events when it has any (split.py): the start
                # piece is held out instead of the end when only it shares them with the training part
                from .split import choose

                self.split_info = choose(self.prob.Y, split)
                self.train, self.test = self.split_info["train"], self.split_info["test"]
        if not self.prob.has_force:
            self.spec.free = [f for f in self.spec.free if not f.name.startswith("input.")]
            self.spec.P["input.offset"] = 0.0
        self.user_floors = floors or {}
        self.cand_filter = candidates
        self.max_effects = max_effects
        self.screen = screen_samples
        self.min_excess_drop = min_excess_drop
        self.min_rel_drop = min_rel_drop
        self.z_min = z_min
        self.beam = beam
        self.far = far
        self.near = near
        self.max_swaps = max_swaps
        self.placements = placements
        self.log = log or (lambda msg: None)
        self.workers = default_workers() if workers is None else max(1, int(workers))

    # --------------------------------------------------------------------------------------------------
    def floors(self) -> dict:
        """Noise floor per channel (in channel units): the user's value or the estimate from the data."""
        out = {}
        for i, c in enumerate(self.prob.channels):
            if c in self.user_floors:
                out[c] = {"value": float(self.user_floors[c]), "source": "user (repeatability)"}
            else:
                v, top, dif = record_floor(self.prob.Y[:, i], self.rec.fs)
                # record_floor: the record's own floor (the lower of the two estimates), which the re-estimation
                # never goes below; top_band, second_differences: the two estimates
                out[c] = {"value": v, "source": "estimated (PSD top band)" if v == top else
                          "estimated (second differences)", "record_floor": v, "top_band": top,
                          "second_differences": dif}
            out[c]["nrmse"] = out[c]["value"] / float(self.prob.scale[i])
        return out

    def recolour(self, floors: dict, fr: FitResult) -> list:
        """Raise the estimated floor of a channel whose residual under the fit ``fr`` (training part) is noise:
        at most ``NOISE_LIKE`` of its power predictable from the inputs and the other channels' residuals
        (:func:`incoherent_noise`).  The top-band estimate assumes white noise and reads coloured noise as
        error; noise is what nothing in the record predicts, whatever its colour.  Needs two or more output
        channels (with one, a nonlinear model error would pass as noise).  Returns the channels raised."""
        chans = self.prob.channels
        if len(chans) < 2:
            return []
        a, b = self.train
        sim = sensor_reading(fr, fr.simulated(self.prob))[a:b]
        U = [u[a:b] for u in self.rec.inputs.values()]
        resid = sim - self.prob.Y[a:b]
        est = incoherent_noise(resid, np.column_stack(U) if U else None)
        raised = []
        for i, c in enumerate(chans):
            std, predictable = est[i]
            if c in self.user_floors:
                continue
            # the record's floor (:func:`record_floor`: the lower of its top band and its second differences),
            # not the residual's: it does not depend on the model, so it reads the same while the model is
            # wrong.  (The record's top band alone read a friction record's body acceleration 1.95× its noise,
            # and that over-read had hidden the fitted friction law's discretisation error: matrix
            # coulomb_friction seed 0 reached 0.0298 against a true floor of 0.0222 at the engine's 0.5 ms
            # step, and a freed tire stiffness took 0.0298 → 0.0263 once the floor was right; the friction law
            # is now fitted at the finer step it asks for, CoulombFriction.fit_step)
            top = float(floors[c].get("record_floor", floors[c]["value"]))
            if predictable > NOISE_LIKE:
                # model error: the floor stays what it was, except a floor raised above the record's on an
                # earlier residual that this model's residual undercuts.  Sensor noise is in every model's
                # residual, so a floor above the residual's RMS was model error taken for noise: on a full car
                # with friction at one corner, the nominal residual of that wheel's acceleration (12× its
                # noise, seen weakly in the other channels) was ≤ 20 % predictable and raised its floor to
                # itself; once the friction was in, that residual held the friction law's error (predictable)
                # and the raise stayed: 12× the true noise, the floors' RMS 3.6× (0.0737 against 0.020), and
                # round 2 was skipped "at the noise floor"
                rms = float(np.sqrt(np.mean(np.square(resid[:, i]))))
                if floors[c]["value"] > top and rms < floors[c]["value"]:
                    new = max(top, rms)
                    floors[c] = {**floors[c], "value": new, "nrmse": new / float(self.prob.scale[i]),
                                 "record_floor": top,
                                 "source": ("estimated (the residual's RMS: a floor raised on an earlier residual "
                                            "is never above a later one)" if new > top else
                                            "estimated (the record's floor: the lower of its PSD top band and "
                                            "second differences)")}
                    getattr(self, "log", lambda m: None)(f"noise floor of {c} lowered to {new:.4g}: it was above this "
                                                f"model's residual ({rms:.4g} RMS)")
                continue
            # white noise: the two estimates agree (within their scatter), and the top-band one stays.  A floor
            # raised on an earlier, worse model's residual comes back to what this one shows (less model error
            # leaks into it), never below the top band
            new = std if std > 1.1 * top else top
            if new == floors[c]["value"]:
                continue
            src = ("estimated (residual not predictable from the inputs or the other channels: coloured noise)"
                   if new > top else "estimated (the record's floor: the lower of its PSD top band and second "
                                     "differences)")
            floors[c] = {**floors[c], "value": new, "source": src, "nrmse": new / float(self.prob.scale[i]),
                         "record_floor": top}
            if new > top:
                raised.append(c)
        return raised

    def screen_end(self, a: int, b: int) -> int:
        """End of the screening window on the training part [a, b) (module docstring): b when the part is
        not long; else a + screen_samples, doubled until every channel's RMS in the window is at least half
        its RMS over the part."""
        if b - a <= max(LONG, 1.5 * self.screen):
            return b
        chans = [np.asarray(x, float)[a:b] for x in (*self.rec.inputs.values(), *self.rec.outputs.values())]
        chans = [x - x.mean() for x in chans if np.std(x) > 0]
        n = self.screen
        while 1.5 * n < b - a:
            if all(np.sqrt(np.mean(x[:n] ** 2)) >= 0.5 * np.sqrt(np.mean(x ** 2)) for x in chans):
                return a + n
            n *= 2
        return b

    def _test_errors(self, fr: FitResult):
        tp = self.test_prob or self.prob
        sim = sensor_reading(fr, fr.simulated(tp))
        a, b = self.test
        a = max(a, tp.skip)
        return (sim[a:b] - tp.Y[a:b]) / tp.scale

    def _gate(self, e_before, e_after, floor_n):
        agg = lambda e: float(np.sqrt(np.mean(e ** 2)))  # noqa: E731 — RMS over samples and channels
        Eb, Ea = agg(e_before), agg(e_after)
        fl2 = float(np.mean(np.square(floor_n)))
        xb = np.sqrt(max(Eb ** 2 - fl2, 0.0))
        xa = np.sqrt(max(Ea ** 2 - fl2, 0.0))
        d = np.sum(e_before ** 2 - e_after ** 2, axis=1)
        blocks = np.array_split(d, 20)
        m = np.array([bb.mean() for bb in blocks])
        se = m.std(ddof=1) / np.sqrt(len(m)) if len(m) > 1 else np.inf
        z = float(m.mean() / se) if se > 0 else (np.inf if m.mean() > 0 else 0.0)
        return Eb, Ea, xb, xa, z

    def _judge(self, tr, fr, cur_screen, e_cur, floor_n, size_names, contained=()):
        """Fill the trial's evidence and decide whether it is kept (the gate of the module docstring)."""
        e_new = self._test_errors(fr)
        Eb, Ea, xb, xa, z = self._gate(e_cur, e_new, floor_n)
        tr.bic, tr.aic = fr.bic(), fr.aic()
        tr.d_bic = fr.bic() - cur_screen.bic()
        tr.test_before, tr.test_after, tr.excess_before, tr.excess_after, tr.z = Eb, Ea, xb, xa, z
        tr.z_spectral = spectral_z(e_cur, e_new)
        ch_b = np.sqrt(np.mean(e_cur ** 2, axis=0))
        ch_a = np.sqrt(np.mean(e_new ** 2, axis=0))
        worse = [c for c, b_, a_, f_ in zip(self.prob.channels, ch_b, ch_a, floor_n) if a_ > b_ + f_]
        # sizes: an effect's size against zero, a freed nominal parameter's change against its stated value
        # an effect is pruned when all its sizes are zero (asymmetric damping with c_comp = 0 is still an effect)
        groups: dict = {}
        for entry in size_names:
            n, ref = (entry, 0.0) if isinstance(entry, str) else entry
            if n in fr.params:
                key = (n.rpartition(".")[0] or n) if isinstance(entry, str) else ("parameter", n)
                groups.setdefault(key, []).append((n, ref))
        zero = [n for members in groups.values() if size_zero(fr, members) for n, _ in members]
        tr.zero_size = bool(zero)
        # a replacement: earlier fitted physics driven to zero by the newcomer (both kept only when separable)
        tr.replaces = self._replaced(cur_screen, fr, [e if isinstance(e, str) else e[0] for e in size_names], contained)
        unsep = [r for r in tr.replaces if not (r["separable"] and z > self.z_min)]
        for r in unsep:
            r["blocking"] = True
        # at the floor (xb = 0) there is nothing above the noise left to explain: "removes 10 % of the error
        # above the floor" must not hold trivially (0 <= 0), or any freed parameter that soaks up a little
        # model error (a wheel mass 0.4 % light) passes on the plain 5 % drop
        at_floor = not xb > 0
        # significant: over contiguous blocks, or against the noise in the residual's spectrum (an effect
        # acting on few samples: the blocks it is not in dilute the block test), or half the excess removed
        signif = z > self.z_min or (self.spectral_gate and tr.z_spectral > self.z_min) or xa <= 0.5 * xb
        ok = bool(tr.d_bic < 0 and signif and xa <= (1 - self.min_excess_drop) * xb and not at_floor
                  and Ea <= (1 - self.min_rel_drop) * Eb and not worse and not zero)
        tr.kept = ok and not unsep
        if at_floor and tr.d_bic < 0 and Ea < Eb:
            tr.reason = f"rejected: the held-out error ({Eb:.4g}) is already at the noise floor"
        if worse:
            tr.reason = f"rejected: held-out error worse beyond the noise on {', '.join(worse)}"
        elif zero:
            tr.reason = f"rejected: size indistinguishable from zero ({', '.join(zero)})"
        elif ok and unsep:
            tr.reason = f"rejected: {NOT_SEPARABLE}: " + "; ".join(
                f"{tr.name} takes the place of {r['parameter']} ({r['before']:.4g} → {r['after']:.4g}, "
                f"correlation {r['correlation']:.3f})" for r in unsep)
        return e_new

    def _replaced(self, cur: FitResult, fr: FitResult, new_sizes: list, contained=()) -> list:
        """Earlier fitted physics that a candidate's fit ``fr`` drives to zero: every vehicle parameter of the
        current model (mass, stiffness, damping) that was distinguishable from zero (beyond 2 standard errors)
        and is no longer (within 2 standard errors of zero, or pushed onto a bound of its band that it was not
        on).  An effect already named is not protected here: when a newcomer takes its place (compound: Coulomb
        friction in place of the hysteresis that stood in for it, correlation 0.98, z 7.1), the newcomer is kept
        and the backward check drops the stand-in, as it drops any effect that no longer earns its place.  Each comes with the largest correlation of its estimate
        with the candidate's sizes in the joint fit (Gauss–Newton covariance): the pair is *separable* only
        when that correlation is below ``RHO_SEPARABLE``.  (EMPS: quadratic damping took the place of the
        viscous friction, 200 → 0.016 N·s/m, over a record whose rates make v and v|v| nearly collinear.)  A
        linear parameter the candidate contains (``contained``: asymmetric damping and the linear damping of its
        corners, :meth:`.candidates.EffectCandidate.augment`) is not replaced when it goes to zero: the effect is
        then a damper on one side only, a generalisation, not a stand-in."""
        from .model import vehicle_params

        veh = set(vehicle_params(self.rec.kind))
        bounds = {f.name: (f.lo, f.hi) for f in fr.spec.free}
        out = []
        for f in cur.spec.free:
            n = f.name
            if n not in veh or n not in fr.P or n in new_sizes or n in contained:
                continue
            v0, s0 = float(cur.P[n]), float(cur.std.get(n, np.nan))
            if not abs(v0) > 2.0 * s0:
                continue  # not established before: nothing to replace
            v1, s1 = float(fr.P[n]), float(fr.std.get(n, np.nan))
            lo, hi = bounds.get(n, (-np.inf, np.inf))
            tol = 0.01 * abs(v0)
            on_bound = lambda v: (np.isfinite(lo) and v - lo <= tol) or (np.isfinite(hi) and hi - v <= tol)  # noqa: E731
            if abs(v1) > 2.0 * s1 and not (on_bound(v1) and not on_bound(v0)):
                continue
            rho = [abs(fr.correlation(n, m)) for m in new_sizes if m in fr.P]
            rho = max([r for r in rho if np.isfinite(r)], default=np.nan)
            out.append({"parameter": n, "before": v0, "after": v1, "std_after": s1, "correlation": float(rho),
                        "separable": bool(rho < RHO_SEPARABLE)})
        return out

    def _set_position_zero(self, spec: ModelSpec):
        """Free (or not) the position channels' offsets as ``spec.position_zero`` says, in every problem."""
        for p in (self.prob, self.test_prob):
            if p is not None:
                p.set_offsets(spec)

    def _position_channels(self) -> list:
        return [c for c in self.prob.channels if is_position(c)]

    def _moves_sag(self, cands) -> bool:
        """Whether the candidates free a parameter that moves the static sag (:func:`sag_params`)."""
        sag = sag_params(self.rec.kind)
        return any(isinstance(c, ParameterCandidate) and c.pname in sag for c in cands)

    def _joint_applies(self, cands, spec: ModelSpec, spec_c: ModelSpec | None = None, points=None) -> bool:
        """Rule (g)'s joint explanation applies: the model's position sensors read zero at the nominal ride
        height, a position channel is measured, and the candidates move the sag, or the model they join
        (``spec_c``, the candidates added) holds a sag-moving parameter an earlier step freed and the candidates
        move where that model settles (:meth:`_moves_rest` at ``points``, parameter sets of ``spec_c``: the
        fit's starts and its plain optimum; default its initial values).  Such a candidate is fitted twice:
        plainly (its sag shows in the positions) and with the positions read from the car's own equilibrium (a
        heavier car re-levelled, or zeroed where it settled); the lower training BIC is judged.  Where a heavier
        car settles depends on every force law of the model (a cubic spring or a stop carries part of its
        weight), so the convention is the whole model's, asked again whenever a candidate changes where a model
        with a freed mass settles: a mass named plainly while the cubic spring was missing (the own zero did not
        pay then) left a cubic spring, added later, no way to the truth's pair (blind battery
        two_heavier_cubic_own: a 5 / 42 mm asymmetric stop stood in for it, 6.4× the floor).  A candidate that
        leaves the rest positions as they are, to the bit (a damping law, friction, a lag, a tire damping), is
        not asked: the two conventions then differ by the same function of the model's own parameters as before
        it joined (asking every joining candidate made every record with a freed mass fit most of its later
        trials twice, for nothing on the nine mass records of the blind battery; docs/diagnose.md)."""
        if not (self.sensor_zero_rule and self.joint_zero and spec.position_zero == "nominal"
                and self._position_channels()):
            return False
        if self._moves_sag(cands):
            return True
        if spec_c is None or not self.joint_model:
            return False
        sag, user = sag_params(self.rec.kind), {f.name for f in self.spec.free}
        if not any(f.name in sag and f.name not in user for f in spec_c.free):
            return False
        if not self.joint_settles:
            return True
        return self._moves_rest(spec, spec_c, [spec_c.vector(spec_c.x0)] if points is None else points)

    def _moves_rest(self, spec: ModelSpec, spec_c: ModelSpec, points) -> bool:
        """Whether the parameters ``spec_c`` frees beyond ``spec`` (the candidates') move where the model
        settles: at any of ``points`` (parameter sets of ``spec_c``), the rest positions (:meth:`.Problem.rest`,
        what the own zero subtracts) change when one of them is stepped as in the fit's Jacobian.  Compared to
        the bit, as "never acts on this record" is: an effect whose force at rest is zero (friction, a damping
        law, hysteresis, a lag) or a stop not engaged at rest leaves them exactly as they are; any change, even
        one in the last bits, takes the joint fit (the safe side)."""
        have = {f.name for f in spec.free}
        new = [i for i, f in enumerate(spec_c.free) if f.name not in have]
        if not new:
            return False
        Ps = []
        for P in points:
            x = np.array([float(P[f.name]) for f in spec_c.free])
            Ps.append(spec_c.vector(x))
            for i in new:
                xi = x.copy()
                xi[i] += 1e-4 * max(abs(x[i]), spec_c.free[i].scale)
                Ps.append(spec_c.vector(xi))
        r = self.prob.rest(spec_c, Ps)
        k = len(new) + 1
        return any(not np.array_equal(r[i], r[i + j]) for i in range(0, len(Ps), k) for j in range(1, k))

    def _offsets_of(self, fr: FitResult) -> dict:
        """The offsets of the position channels (SI units: what the sensors read at the nominal ride height):
        the fitted ones, or under ``position_zero: own`` minus the model's rest positions (its sag)."""
        if fr.spec.position_zero == "own":
            r = self.prob.rest(fr.spec, [fr.P])[0]
            return {c: -float(r[self.prob.channels.index(c)]) for c in self._position_channels()}
        return {c: float(fr.offsets[self.prob.channels.index(c)]) if fr.offsets is not None else 0.0
                for c in self._position_channels()}

    def _offsets_zero(self, fr: FitResult, a: int, b: int) -> bool:
        """Whether a fit's position offsets are together indistinguishable from zero (gate (f) for the offsets:
        the Wald statistic Σ (o/se)² below the χ² quantile of :func:`size_zero`'s level).  Each offset is the mean
        residual of its channel on [a, b): its standard error is the residual's std over √N_eff, N_eff from the
        residual's autocorrelation (:func:`.calibrate.effective_n`).  The BIC counts every sample as independent:
        on brown sensor noise the mean of the noise over the window passed for an offset (blind battery
        heavier_truck: a joint fit with a 0.05 mm travel offset beat the plain one by BIC, while its sag was in
        the record)."""
        from scipy.stats import chi2

        from .calibrate import effective_n

        offs = self._offsets_of(fr)
        a = max(a, self.prob.skip)
        sim = sensor_reading(fr, fr.simulated(self.prob))
        w = 0.0
        chans = self._position_channels()
        for c in chans:
            i = self.prob.channels.index(c)
            r = sim[a:b, i] - self.prob.Y[a:b, i]
            se = float(np.std(r)) / np.sqrt(max(effective_n(r[:, None]), 1.0))
            if not se > 0:
                return False
            w += (offs[c] / se) ** 2
        return not w > chi2.ppf(chi2.cdf(ZERO_Z ** 2, 1), len(chans))

    def _rival(self, spec: ModelSpec, start: FitResult, a: int, bs: int) -> FitResult:
        """Rule (g)'s rival: ``spec`` (from ``start``'s optimum) with a free offset on every position channel and
        nothing else freed (a sag-moving parameter at its stated value); the offsets pay log n each in the BIC."""
        spec_z = _with_fit(spec, start)
        spec_z.position_zero = "measured"
        return fit(self.prob, spec_z, a, bs, max_nfev=60)

    def _against_rival(self, kept: list, held: list, bic_r: float, why: str, rival: str, tail: str):
        """Hold each kept result in ``held`` against a rival explanation's training BIC ``bic_r`` (rules (g) and
        (h)): one whose BIC is not lower is no longer kept (reason: ``why`` and the two BICs).  Returns (the kept
        results left, [{candidate, bic}] of those the rival beat)."""
        out, beaten = [], []
        for r in kept:
            tr = r[2]
            mine = any(r is m for m in held)
            if mine and bic_r <= tr.bic:
                tr.kept = False
                tr.reason = f"rejected: {why}, training BIC {bic_r:.1f} against {tr.bic:.1f})"
                beaten.append({"candidate": tr.name, "bic": float(tr.bic)})
                self.log(f"  {tr.name}: {tr.reason[len('rejected: '):]}")
            else:
                if mine:
                    self.log(f"  {tr.name}: beats {rival}: training BIC {tr.bic:.1f} against {bic_r:.1f}{tail})")
                out.append(r)
        return out, beaten

    def _sensor_zero(self, kept: list, results: list, current_spec: ModelSpec, cur_screen: FitResult, e_cur,
                     floor_n, a: int, bs: int, b: int):
        """Rule (g) (module docstring): the rival explanation, the current model with a free offset on every
        position channel and nothing else freed, is fitted when a candidate that moves the sag was kept, or was
        fitted better beside free position offsets than without (its joint fit won: the positions are off the
        nominal zero by BIC, kept or not).  Each kept sag-moving result is held against it by training BIC (the
        rival pays log n per offset), and the rival is judged by the usual gates.  Returns (the kept results it
        leaves, and (spec, screening fit, fit, finding) of the rival when the gates keep it and no kept result
        has a lower BIC, else None)."""
        if current_spec.position_zero != "nominal":
            return kept, None
        moving = [r for r in kept if self._moves_sag(r[0])]
        joint = [r for r in results if r[2].own_zero and self._moves_sag(r[0])]
        freed = self._position_channels()
        if not (moving or joint) or not freed:
            return kept, None
        fs = self._rival(current_spec, cur_screen, a, bs)
        bic_z = fs.bic()
        trz = Trial("position sensors' zero", 0, True)
        self._judge(trz, fs, cur_screen, e_cur, floor_n, [])
        self.log(f"  rule (g): the position sensors' zero (a free offset on {', '.join(freed)}) ΔBIC {trz.d_bic:.1f}  "
                 f"test NRMSE {trz.test_before:.4f} → {trz.test_after:.4f}  z {trz.z:.1f}  "
                 f"{'passes the gate' if trz.kept else trz.reason or 'fails the gate'}")
        out, beaten = self._against_rival(
            kept, moving, bic_z, f"the position sensors' zero explains it better (rule (g): a free offset on "
                                 f"{', '.join(freed)} at the stated value",
            "the position sensors' zero (rule (g)", f" with a free offset on {', '.join(freed)}")
        for r in joint:  # joint fits that won over their plain fit but were not kept: the offsets did the work
            if not r[2].kept and bic_z <= r[2].bic and not any(bb["candidate"] == r[2].name for bb in beaten):
                beaten.append({"candidate": r[2].name, "bic": float(r[2].bic)})
                r[2].reason += (f"; the position sensors' zero explains it better (rule (g): the offsets alone, "
                                f"training BIC {bic_z:.1f} against {r[2].bic:.1f})")
        if not trz.kept or not beaten or any(r[2].bic < bic_z for r in out):
            return out, None
        fr = fs
        if bs < b:
            fr = fit(self.prob, _with_fit(fs.spec, fs), a, b, max_nfev=30)
        finding = {"offsets": self._offsets_of(fr), "bic": float(bic_z),
                   "bic_before": float(cur_screen.bic()), "beats": beaten,
                   "test_before": float(trz.test_before), "test_after": float(trz.test_after), "z": float(trz.z)}
        return out, (fs.spec, fs, fr, finding)

    def gain_finding(self, fr: FitResult, a: int, b: int) -> dict:
        """The output channels' fitted gains (rule (h)) with their standard errors: each gain is the slope of a
        line through the simulated against the measured samples on [a, b), so its standard error is the
        residual's std over √(N_eff·mean(s_c²)) (s_c: the simulation, centred when the channel's offset is
        free; N_eff from the residual's autocorrelation, as for the offsets of :meth:`_offsets_zero`)."""
        from .calibrate import effective_n

        a = max(a, self.prob.skip)
        raw = fr.simulated(self.prob)[a:b]
        res = sensor_reading(fr, fr.simulated(self.prob))[a:b] - self.prob.Y[a:b]
        mask = self.prob.mask(fr.spec)
        out = {"gains": {}, "std": {}}
        for i, c in enumerate(self.prob.channels):
            s_c = raw[:, i] - (raw[:, i].mean() if mask[i] else 0.0)
            ms = float(np.mean(s_c ** 2))
            se = float(np.std(res[:, i])) / np.sqrt(max(effective_n(res[:, i:i + 1]), 1.0) * ms) if ms > 0 else np.inf
            out["gains"][c] = float(fr.gains[i]) if fr.gains is not None else 1.0
            out["std"][c] = se
        return out

    def gains_identifiable(self) -> bool:
        """Whether free output gains can be told apart from the vehicle (rule (h)): a measured displacement input
        (a road or a rig's base) excites the car.  Its response does not change when every mass, stiffness and
        damping is scaled alike, so no parameter set reproduces a scaled output.  Driven by a force alone (a
        rig's shaker), that scaling scales every output: a gain is then the scale of the free parameters, as
        on a damper rig (its one force channel)."""
        if self.rec.kind == "damper":
            return False
        return any((k.startswith("road") or k == "base") and np.any(v) for k, v in self.prob.inputs.items())

    def _sensor_gain(self, kept: list, current_spec: ModelSpec, cur_screen: FitResult, e_cur, floor_n,
                     a: int, bs: int, b: int, remainder: bool = False):
        """Rule (h) (module docstring): a kept candidate that frees a vehicle parameter is held against the rival
        explanation, the current model with a free gain on every output channel (the parameter at its stated
        value; the gains eliminated in closed form, log n each in the BIC), by training BIC.  The rival is judged
        by the usual gates.  ``remainder``: nothing was kept and the model is still above the floor; the gains
        are tried alone, judged by the same gates.  Returns (the kept results it leaves, and (spec, screening fit,
        fit, finding) of the rival when the gates keep it and no kept result has a lower BIC, else None)."""
        if current_spec.gains or not self.gains_identifiable():
            return kept, None
        freeing = [r for r in kept if any(isinstance(c, ParameterCandidate) for c in r[0])]
        if not freeing and not remainder:
            return kept, None
        spec_g = _with_fit(current_spec, cur_screen)
        spec_g.gains = True
        fs = fit(self.prob, spec_g, a, bs, max_nfev=60)
        bic_g = fs.bic()
        trg = Trial("sensor gains", 0, True)
        self._judge(trg, fs, cur_screen, e_cur, floor_n, [])
        self.log(f"  rule (h): the sensors' gains (a free gain on {', '.join(self.prob.channels)}: "
                 + ", ".join(f"{g:.4f}" for g in fs.gains) + f") ΔBIC {trg.d_bic:.1f}  test NRMSE "
                 f"{trg.test_before:.4f} → {trg.test_after:.4f}  z {trg.z:.1f}  "
                 f"{'passes the gate' if trg.kept else trg.reason or 'fails the gate'}")
        out, beaten = self._against_rival(
            kept, freeing, bic_g, "the sensors' gains explain it better (rule (h): a free gain on every output "
                                  "channel, the parameter at its stated value", "the sensors' gains (rule (h)", "")
        fl = float(np.sqrt(np.mean(np.square(floor_n))))
        if remainder and trg.kept and not trg.test_after <= self.near * fl:
            # the gains alone are a sensor finding only when they explain the remainder (the model within ``near``
            # of the floor); else they stand in for model error (a c.g. shift on the half car: 64× the floor)
            self.log(f"  rule (h): the gains leave {trg.test_after / max(fl, 1e-12):.1f}× the floor: not a sensor "
                     f"finding")
            return out, None
        if not trg.kept or not (beaten or remainder) or any(r[2].bic < bic_g for r in out):
            return out, None
        fr = fs
        if bs < b:
            fr = fit(self.prob, _with_fit(fs.spec, fs), a, b, max_nfev=30)
        finding = {**self.gain_finding(fr, a, b), "bic": float(bic_g), "bic_before": float(cur_screen.bic()),
                   "beats": beaten, "test_before": float(trg.test_before), "test_after": float(trg.test_after),
                   "z": float(trg.z)}
        return out, (fs.spec, fs, fr, finding)

    def _polish(self, spec_c: ModelSpec, fr: FitResult, a: int, bs: int, b: int) -> tuple[FitResult, FitResult]:
        """Refit a kept candidate from its own optimum (longer, and on the whole training part when it was
        screened on less).  A refit never replaces a better fit: the polish is kept only when its training
        cost on the same window is not higher (a least-squares run started at an optimum cannot rise unless
        it started elsewhere), and the whole-window refit only when it is not worse on held-out data by more
        than ``min_rel_drop``.  (Lag case: a polish that rose from held-out 0.020 to 0.21 was kept, and a
        freed unsprung mass was then named for restoring it.)  Returns (the fit on the screening window [a, bs),
        the fit to carry on with); the first is the next round's screening baseline."""
        p1 = fit(self.prob, _with_fit(spec_c, fr), a, bs, max_nfev=100)
        if p1.cost <= fr.cost * (1 + 1e-6):
            fr = p1
        else:
            self.log(f"  polish rose from {fr.cost:.4g} to {p1.cost:.4g} (training cost): the trial fit is kept")
        screened = fr
        if bs < b:
            p2 = fit(self.prob, _with_fit(spec_c, fr), a, b, max_nfev=30)
            rms = lambda f: float(np.sqrt(np.mean(self._test_errors(f) ** 2)))  # noqa: E731
            if rms(p2) <= rms(fr) * (1 + self.min_rel_drop):
                fr = p2
            else:
                self.log("  the whole-window refit is worse on held-out data: the screened fit is kept")
        return screened, fr

    def _pairs(self, results: list, tried: set) -> tuple[list, list]:
        """The beam over pairs: (members, index pairs to try).  Members are the ``beam`` single trials with the
        lowest training BIC among those that lowered it (and were not pruned as zero-size); a pair is tried
        when its members are different effects, it was not tried before (``tried`` is updated), and at least
        one member alone lowered the held-out error.  Two effects that each only make unseen data worse are
        not tried together: on EMPS (an encoder, so its floor is tiny and pairs were always tried) every
        single of round 2 made the PULSES test worse, and its pairs, most of a 25–34 min run, kept nothing."""
        members = sorted([r for r in results if np.isfinite(r[2].bic) and r[2].d_bic < 0
                          and not r[2].reason.startswith("rejected: size")], key=lambda r: r[2].bic)[:self.beam]
        gain = [r[2].test_after < r[2].test_before for r in members]
        pairs = []
        for i in range(len(members)):
            for j in range(i + 1, len(members)):
                ci, cj = members[i][0][0], members[j][0][0]
                key = frozenset((ci.name, cj.name))
                if ci.name.split("@")[0] == cj.name.split("@")[0] or key in tried or not (gain[i] or gain[j]):
                    continue
                tried.add(key)
                pairs.append((i, j))
        return members, pairs

    def _exchange_pool(self, trials: list, lib: list, in_model: set) -> list:
        """The candidates an exchange tries in place of an effect of the model: the ``beam`` single candidates
        of round 1 (each alone against the calibrated nominal model) with the lowest training BIC among those
        that lowered it and were not pruned as zero-size, less those in the model.  Round 1 is where each
        effect shows what it explains alone; later rounds judge it beside effects that may stand in for it."""
        byname = {c.name: c for c in lib}
        ok = sorted([t for t in trials if t.round == 1 and t.applicable and t.name in byname
                     and t.name not in in_model and np.isfinite(t.bic) and np.isfinite(t.d_bic) and t.d_bic < 0
                     and not t.zero_size], key=lambda t: t.bic)
        return [byname[t.name] for t in ok[:self.beam]]

    def _confirm(self, tr: Trial, fr: FitResult, current: FitResult, e_cur, floor_n, cands) -> bool:
        """A candidate kept on the screening window, refitted on the whole training part (``fr``), is judged
        again against the current whole-window model by the same gate.  The trial's evidence becomes the
        whole-window one (the screening one is kept in ``tr.screened``); when it fails, the trial is not kept."""
        screened = {k: getattr(tr, k) for k in ("d_bic", "test_before", "test_after", "excess_before",
                                                 "excess_after", "z", "z_spectral")}
        chk = Trial(tr.name, tr.round, True)
        self._judge(chk, fr, current, e_cur, floor_n, [s for c in cands for s in c.size_names],
                    _contained(cands))
        for k in screened:
            setattr(tr, k, getattr(chk, k))
        tr.bic, tr.aic, tr.replaces, tr.screened = chk.bic, chk.aic, chk.replaces, screened
        self.log(f"  whole training part: {tr.name} ΔBIC {chk.d_bic:.1f}  test NRMSE {chk.test_before:.4f} → "
                 f"{chk.test_after:.4f}  z {chk.z:.1f} / {chk.z_spectral:.1f}  {'confirmed' if chk.kept else chk.reason or 'not kept'}")
        if not chk.kept:
            tr.kept = False
            tr.reason = ("kept on the screening window, rejected on the whole training part: "
                         + (chk.reason or "the gate fails there"))
        return chk.kept

    # --------------------------------------------------------------------------------------------------
    def run(self) -> Diagnosis:
        """The search (module docstring).  Candidates of a round are fitted side by side in ``workers`` threads
        (the compiled loop releases the GIL; each fit is independent, and the trials and the log keep the
        library's order, so the result does not depend on the number of threads)."""
        if self.workers <= 1:
            return self._search(None)
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(self.workers, thread_name_prefix="diagnose") as pool:
            return self._search(pool)

    def _search(self, pool) -> Diagnosis:
        import time

        sensor_zero = sensor_gain = None

        T = {}
        t0 = time.perf_counter()
        floors = self.floors()
        a, b = self.train
        if self.split_info is not None and self.split_info["by_events"]:
            self.log(self.split_info["reason"])
        self.log(f"calibrating the nominal model ({', '.join(self.spec.names()) or 'nothing free'}) on "
                 f"{b - a} training samples")
        bs = self.screen_end(a, b)
        nominal = fit(self.prob, self.spec, a, bs, max_nfev=100)
        nominal_screen = nominal
        if bs < b:
            nominal = fit(self.prob, _with_fit(self.spec, nominal), a, b, max_nfev=30)
        T["calibrate"] = time.perf_counter() - t0
        for c in self.recolour(floors, nominal):
            self.log(f"noise floor of {c} raised to {floors[c]['value']:.4g}: the nominal residual is coloured noise")
        floor_n = np.array([floors[c]["nrmse"] for c in self.prob.channels])
        current_spec = _with_fit(self.spec, nominal)
        current = nominal
        sc = _scales(self.prob, current_spec, nominal.P, b, a)
        # screened candidates are judged against the current model fitted on the same window (like with like:
        # the whole-window model is better on held-out data than any refit on 8 000 samples, by more than a
        # second effect's gain on the Silverbox), and the chosen one again on the whole window (below)
        cur_screen = nominal_screen
        lib = library(current_spec, placements=self.placements)
        if self.cand_filter is not None:
            lib = [c for c in lib if c.name.split("@")[0] in self.cand_filter
                   or (c.name.startswith("parameter:") and "parameter" in self.cand_filter)]
        added, trials = [], []
        e_cur = self._test_errors(current)
        e_screen = self._test_errors(cur_screen) if bs < b else e_cur
        tried_pairs = set()

        def attempt(cands, rnd, current_spec, current, cur_screen, e_cur, starts_from=(), parent=None, label=None):
            name = label or "+".join(c.name for c in cands)
            tr = Trial(name, rnd, True)
            t1 = time.perf_counter()
            spec_c, starts = current_spec, None
            sizes = []
            for c in cands:
                before = [f.name for f in spec_c.free]
                spec_c, st = c.augment(spec_c, sc)
                sizes += list(c.size_names)
                if starts is not None:  # a pair: each start of the first with the second's own (by name)
                    names_c = [f.name for f in spec_c.free]
                    st = [[dict(zip(before, s0)).get(nm, v) for nm, v in zip(names_c, st[0])] for s0 in starts]
                starts = st
            for fr0 in starts_from:  # a pair starts from each member's own fit too
                starts.append([fr0.P.get(f.name, f.init) for f in spec_c.free])
            if len(spec_c.free) == len(current_spec.free):
                # an effect with nothing to fit (tire lift-off) that never acts on this record leaves the model's
                # outputs as they are, to the bit: its fit would be the current model's (ΔBIC −0.0 on the full
                # car's speed record, 18 s of refitting the dampings for nothing there, and more before the
                # placement rule)
                same = np.array_equal(self.prob.simulate(spec_c, current.P, 0, bs),
                                      self.prob.simulate(current_spec, current.P, 0, bs))
                if same:
                    tr.applicable, tr.reason = False, "never acts on this record (the outputs are unchanged)"
                    tr.seconds = time.perf_counter() - t1
                    return tr, f"  round {rnd} {name:<36} {tr.reason}", None
            first = None
            if parent is not None:
                # a placement starts from its parent's fit (the same effect on more corners, fitted in this round:
                # its multi-start has already chosen the branch, e.g. which bump stops engage); its own declared
                # starts only when that fit does not lower the training cost (a cubic spring fitted on all four
                # corners, put on the rear alone, made the car diverge and the fit stopped there: ΔBIC +96 051)
                pname, pfr = parent
                own = f"{cands[0].name}."
                first = [[pfr.P.get(f"{pname}.{f.name[len(own):]}" if f.name.startswith(own) else f.name, f.init)
                          for f in spec_c.free]]
            fr = None
            for st in ([first] if first is not None else []) + [starts]:
                try:
                    f1 = fit(self.prob, spec_c, a, bs, starts=[np.array(s0, float) for s0 in st], max_nfev=25)
                except RuntimeError as err:
                    if fr is None and st is starts:
                        tr.applicable, tr.reason = False, f"fit failed: {err}"
                        return tr, None, None
                    continue
                fr = f1 if fr is None or f1.cost < fr.cost else fr
                if fr.cost < cur_screen.cost:
                    break
                if st is first and fr.n * np.log(fr.cost / cur_screen.cost) <= np.log(fr.n):
                    # the placement's fit from its parent's optimum is the current model to within one
                    # parameter's BIC penalty: the effect went to zero size there (nothing at these corners),
                    # not off to a diverged branch (the cubic spring's ΔBIC +96 051 above); its declared
                    # starts would fit the same nothing again (the full car's single-corner friction record:
                    # the rear axle's and the empty corner's placements, about a quarter of round 1's time)
                    break
            if self._joint_applies(cands, current_spec, spec_c,
                                   [spec_c.vector(np.array(s0, float)) for s0 in starts] + [fr.P]):
                # rule (g), the joint explanation: the same candidates with the positions read from the model's
                # own equilibrium (the sag is not in the record: each set's rest positions are subtracted,
                # Problem.rest); the lower training BIC of the two is judged (the same parameters: a choice of
                # convention, not free offsets)
                spec_j = spec_c.copy()
                spec_j.position_zero = "own"
                try:
                    fj = fit(self.prob, spec_j, a, bs, starts=[np.array(s0, float) for s0 in starts], max_nfev=25)
                except RuntimeError:
                    fj = None
                if fj is not None and fj.bic() < fr.bic() and not self._offsets_zero(fj, a, bs):
                    tr.own_zero = {"offsets": self._offsets_of(fj), "bic": float(fj.bic()),
                                   "bic_plain": float(fr.bic())}
                    spec_c, fr = spec_j, fj
            tr.params = {k: v for k, v in fr.params.items() if k not in current.params}
            self._judge(tr, fr, cur_screen, e_cur, floor_n, sizes, _contained(cands))
            tr.seconds = time.perf_counter() - t1
            msg = (f"  round {rnd} {name:<36} ΔBIC {tr.d_bic:12.1f}  test NRMSE {tr.test_before:.4f} → "
                   f"{tr.test_after:.4f}  z {tr.z:6.1f} / {tr.z_spectral:6.1f}  {tr.seconds:5.1f} s  {'KEPT' if tr.kept else tr.reason}")
            if tr.own_zero:
                msg += (f"\n      (fitted with the positions from the car's own equilibrium, offsets "
                        + ", ".join(f"{c} {1e3 * o:+.2f} mm" for c, o in tr.own_zero["offsets"].items())
                        + f"; training BIC {tr.own_zero['bic']:.1f} against {tr.own_zero['bic_plain']:.1f} without)")
            return tr, msg, (list(cands), spec_c, tr, fr)

        def attempts(jobs, order=None):
            """Run attempt(*job) for every job, side by side in threads (each fit is independent); the trials
            and log lines come in the order of ``order`` (Trials not tried, and job indices), else of the jobs.
            Returns the results of the jobs that could be fitted, in order."""
            outs = list(pool.map(lambda job: attempt(*job[0], **job[1]), jobs)) if pool is not None else \
                [attempt(*job[0], **job[1]) for job in jobs]
            done = []
            for o in (range(len(jobs)) if order is None else order):
                if isinstance(o, Trial):
                    trials.append(o)
                    continue
                tr, msg, r = outs[o]
                trials.append(tr)
                if msg:
                    self.log(msg)
                if r is not None:
                    done.append(r)
            return done

        def exchange(rnd, current_spec, current, cur_screen, e_cur, e_screen, floor_n):
            """One exchange round (:meth:`_exchange_pool`): each effect of the model replaced by each of the best
            single candidates of round 1, fitted and judged against the current model by the same gate; returns
            (the effect taken out, the candidates put in, their spec, trial, screened fit, fit) or None."""
            Ecur = float(np.sqrt(np.mean(e_cur ** 2)))
            fl = float(np.sqrt(np.mean(floor_n ** 2)))
            flat = [c for cs, _, _ in added for c in cs]
            if not flat or not Ecur > self.near * fl:
                return None
            pool = self._exchange_pool(trials, lib, {c.name for c in flat})
            jobs, outs, bases = [], [], []
            for out_c in flat:
                spec_r = _with_fit(self.spec, nominal)
                spec_r.position_zero = current_spec.position_zero
                spec_r.gains = current_spec.gains
                for cand in flat:
                    if cand is not out_c:
                        spec_r, _st = cand.augment(spec_r, sc)
                for f in spec_r.free:
                    if f.name in current.P:
                        f.init = current.P[f.name]
                        spec_r.P[f.name] = current.P[f.name]
                for cand in pool:
                    if cand.name.split("@")[0] == out_c.name.split("@")[0] or not cand.applies(spec_r, sc)[0]:
                        continue
                    jobs.append((([cand], rnd, spec_r, current, cur_screen, e_screen),
                                 {"label": f"{cand.name} in place of {out_c.name}"}))
                    outs.append(out_c)
                    bases.append(spec_r)
            if not jobs:
                return None
            self.log(f"  exchange at {Ecur / max(fl, 1e-12):.1f}× the noise floor: "
                     + ", ".join(sorted({c.name for c in pool})) + " in place of " + ", ".join(c.name for c in flat))
            n0 = len(trials)
            res = attempts(jobs)
            by_trial = {id(t): outs[k] for k, t in enumerate(trials[n0:])}
            base_of = {id(t): bases[k] for k, t in enumerate(trials[n0:])}
            rivals = {}
            for cands, spec_c, tr, fr in sorted([r for r in res if r[2].kept], key=lambda r: r[2].bic):
                base = base_of[id(tr)]
                if self.sensor_zero_rule and base.position_zero == "nominal" and self._position_channels() \
                        and self._moves_sag(cands):
                    # rule (g) on an exchange: a sag-moving newcomer against the model it joins (the effect
                    # taken out) with free position offsets instead, by training BIC
                    key = id(base)
                    if key not in rivals:
                        rivals[key] = self._rival(base, cur_screen, a, bs).bic()
                    if rivals[key] <= tr.bic:
                        tr.kept = False
                        tr.reason = (f"rejected: the position sensors' zero explains it better (rule (g): a free "
                                     f"offset on {', '.join(self._position_channels())} in place of "
                                     f"{by_trial[id(tr)].name}, training BIC {rivals[key]:.1f} against {tr.bic:.1f})")
                        self.log(f"  {tr.name}: {tr.reason[len('rejected: '):]}")
                        continue
                fs, fr = self._polish(spec_c, fr, a, bs, b)
                if bs < b and not self._confirm(tr, fr, current, e_cur, floor_n, cands):
                    continue
                return by_trial[id(tr)], cands, spec_c, tr, fs, fr
            return None

        def adopt(spec_c, fr, fs):
            """The model ``fr`` (screened as ``fs``) becomes the current one: (its spec, fit, screening fit, test
            errors on the whole and screening windows, the per-channel floor re-estimated from its residual)."""
            e_c = self._test_errors(fr)
            e_s = self._test_errors(fs) if bs < b else e_c
            self._set_position_zero(spec_c)  # the joint explanation of rule (g) frees the position offsets
            self.recolour(floors, fr)
            return (_with_fit(spec_c, fr), fr, fs, e_c, e_s,
                    np.array([floors[c]["nrmse"] for c in self.prob.channels]))

        rnd = 0
        swaps = 0
        while True:
            while len(added) < self.max_effects:
                rnd += 1
                prev = {t.name: t for t in trials if t.round == rnd - 1}
                in_model = {c.name for cs, _, _ in added for c in cs}
                # nested placements (the full car): a candidate with a parent placement is tried after it, and only
                # when the parent lowered the training BIC in this round by more than PLACEMENT_BIC with a size
                # distinguishable from zero (an effect on the front corners lowers it everywhere too, as a weaker
                # effect on all four), from the parent's fit; the others first, in one batch
                results, this_round = [], {}
                stage = [c for c in lib if c.parent is None]
                parents = {}  # a placement's (parent name, parent's fit in this round): its start
                # a candidate that did not lower the training BIC last round is pruned, unless the current model is
                # still far above the floor: an effect masked by another (friction fitted to zero while a missing
                # lag dominated; the blind battery's two_lag_coulomb) gets another chance once that one is in
                # (the current model's held-out error and the floor stay the same through the round: the pair beam
                # below asks the same question)
                Ecur = float(np.sqrt(np.mean(e_cur ** 2)))
                fl = float(np.sqrt(np.mean(floor_n ** 2)))
                far_now = Ecur > self.far * fl
                if rnd > 1 and self.skip_at_floor:
                    # at the floor, nothing in this round can be kept (module docstring, "Speed"): every trial,
                    # single or pair, is judged against the same screening-window errors, and gate (c) needs an
                    # excess above the floor to remove
                    Es, _, xs, _, _ = self._gate(e_screen, e_screen, floor_n)
                    if not xs > 0:
                        why = (f"not fitted: the held-out error of the model so far ({Es:.4g}) is at the noise "
                               f"floor ({fl:.4g}): no candidate can pass the gate")
                        self.log(f"  round {rnd}: {why[len('not fitted: '):]}")
                        trials.extend(Trial(c.name, rnd, False, why) for c in lib if c.name not in in_model)
                        break
                while stage:
                    jobs, order = [], []
                    for cand in stage:
                        if cand.name in in_model:
                            continue
                        ok, why = cand.applies(current_spec, sc)
                        pt = prev.get(cand.name)
                        if (ok and not far_now and pt is not None and pt.applicable and np.isfinite(pt.d_bic)
                                and pt.d_bic >= 0):
                            ok, why = False, f"pruned: no training improvement in round {rnd - 1} (ΔBIC {pt.d_bic:+.1f})"
                        if not ok:
                            order.append(Trial(cand.name, rnd, False, why))
                            continue
                        order.append(len(jobs))
                        jobs.append((([cand], rnd, current_spec, current, cur_screen, e_screen),
                                     {"parent": parents.get(cand.name)}))
                    n0 = len(trials)
                    results += attempts(jobs, order)
                    this_round.update({t.name: t for t in trials[n0:]})
                    done, stage = {c.name for c in stage}, []
                    fits = {r[2].name: r[3] for r in results}
                    for cand in lib:  # (the library lists a placement after its parent)
                        if cand.parent is None or cand.parent not in done:
                            continue
                        why = placement_refused(this_round.get(cand.parent))
                        if not why and cand.parent in fits:
                            stage.append(cand)
                            parents[cand.name] = (cand.parent, fits[cand.parent])
                        elif cand.name not in in_model:
                            trials.append(Trial(cand.name, rnd, False, f"not tried: {cand.parent} {why or 'was not fitted'}"
                                                                       f" in this round"))
                            this_round[cand.name] = trials[-1]
                            done.add(cand.name)  # its own placements are not tried either
                kept = [r for r in results if r[2].kept]
                if not kept and far_now and self.max_effects - len(added) >= 2:
                    # beam over pairs: the best candidates by training cost, two at a time (:meth:`_pairs`)
                    ok_res, pairs = self._pairs(results, tried_pairs)
                    self.log(f"  no single candidate kept at {Ecur / max(fl, 1e-12):.1f}× the noise floor: "
                             f"pairs of {', '.join(r[2].name for r in ok_res)}"
                             + ("" if pairs else " (no pair: no member lowers the held-out error alone)"))
                    jobs = [(([ok_res[i][0][0], ok_res[j][0][0]], rnd, current_spec, current, cur_screen, e_screen),
                             {"starts_from": (ok_res[i][3], ok_res[j][3])}) for i, j in pairs]
                    kept += [r for r in attempts(jobs) if r[2].kept]
                zero = None
                if self.sensor_zero_rule:
                    kept, zero = self._sensor_zero(kept, results, current_spec, cur_screen, e_screen, floor_n,
                                                   a, bs, b)
                if zero is not None:
                    # rule (g): the position sensors' zero is adopted (no effect named), and the search goes on
                    spec_z, fs_z, fr_z, sensor_zero = zero
                    current_spec, current, cur_screen, e_cur, e_screen, floor_n = adopt(spec_z, fr_z, fs_z)
                    self.log("adopted free position-sensor offsets (rule (g)): " + ", ".join(
                        f"{c} {1e3 * o:+.2f} mm" for c, o in sensor_zero["offsets"].items()))
                    continue
                gain, chosen = None, None
                if self.sensor_gain_rule:
                    kept, gain = self._sensor_gain(kept, current_spec, cur_screen, e_screen, floor_n, a, bs, b)
                for cands, spec_c, tr, fr in (sorted(kept, key=lambda r: r[2].bic) if gain is None else []):
                    fs, fr = self._polish(spec_c, fr, a, bs, b)
                    if bs < b and not self._confirm(tr, fr, current, e_cur, floor_n, cands):
                        continue
                    chosen = (cands, spec_c, tr, fs, fr)
                    break
                if (gain is None and chosen is None and self.sensor_gain_rule and not kept and not current_spec.gains
                        and Ecur > self.near * fl):
                    # rule (h) for the remainder: no effect or parameter is kept while the model is still above the
                    # floor; the output channels' gains alone, by the same gates
                    _, gain = self._sensor_gain([], current_spec, cur_screen, e_screen, floor_n, a, bs, b,
                                                remainder=True)
                if gain is not None:
                    # rule (h): the sensors' gains are adopted (no parameter named), and the search goes on
                    spec_g, fs_g, fr_g, sensor_gain = gain
                    current_spec, current, cur_screen, e_cur, e_screen, floor_n = adopt(spec_g, fr_g, fs_g)
                    self.log("adopted free sensor gains (rule (h)" + (")" if sensor_gain["beats"] else ", the remainder)")
                             + ": " + ", ".join(f"{c} {g:.4f} ± {sensor_gain['std'][c]:.4f}"
                                                for c, g in sensor_gain["gains"].items()))
                    continue
                if chosen is None:
                    break
                cands, spec_c, tr, fs, fr = chosen
                added.append((cands, fr, tr))
                self.log(f"added {tr.name}: {fr.params}")
                # the floor from the best model's residual: while the residual held model error the floor was the
                # top-band one (coloured noise reads low there: suv_bumps' round 2 ran its pair beam at "4.3× the
                # floor" with the stop already in and a residual that was noise)
                floor_was = floor_n
                current_spec, current, cur_screen, e_cur, e_screen, floor_n = adopt(spec_c, fr, fs)
                if not np.array_equal(floor_n, floor_was):
                    self.log("  noise floor from the residual of the model so far: " + ", ".join(
                        f"{c} {floors[c]['value']:.4g}" for c in self.prob.channels))
            # exchange: the forward search is greedy, and an effect added early can stand in for one that only
            # shows once another is in (blind battery two_asym_cubic: a stop stood in for the cubic spring while
            # the asymmetric damping was missing, then nothing beside the stop and the damping improved on them)
            if swaps >= self.max_swaps:
                break
            sw = exchange(rnd + 1, current_spec, current, cur_screen, e_cur, e_screen, floor_n)
            if sw is None:
                break
            rnd += 1
            swaps += 1
            out_c, cands, spec_c, tr, fs, fr = sw
            added = [([c for c in cs if c is not out_c], current, t) for cs, _, t in added]
            added = [(cs, fr, t) for cs, _, t in added if cs] + [(list(cands), fr, tr)]
            self.log(f"exchanged {out_c.name} for {cands[0].name}: {fr.params}")
            current_spec, current, cur_screen, e_cur, e_screen, floor_n = adopt(spec_c, fr, fs)
        # backward check
        removed = True
        while removed and sum(len(cs) for cs, _, _ in added) >= 2:
            removed = False
            E_full = float(np.sqrt(np.mean(self._test_errors(current) ** 2)))
            flat = [(c, k) for k, (cs, _, _) in enumerate(added) for c in cs]
            for drop in range(len(flat)):
                keep = [c for i, (c, _) in enumerate(flat) if i != drop]
                spec_r = _with_fit(self.spec, nominal)
                spec_r.position_zero = current_spec.position_zero
                spec_r.gains = current_spec.gains
                for cand in keep:
                    spec_r, _st = cand.augment(spec_r, sc)
                for f in spec_r.free:
                    if f.name in current.P:
                        f.init = current.P[f.name]
                        spec_r.P[f.name] = current.P[f.name]
                try:
                    fr_r = fit(self.prob, spec_r, a, b, max_nfev=60)
                except RuntimeError:
                    continue
                E_r = float(np.sqrt(np.mean(self._test_errors(fr_r) ** 2)))
                if E_r <= E_full / (1 - self.min_rel_drop) and fr_r.bic() <= current.bic():
                    cand = flat[drop][0]
                    self.log(f"dropped {cand.name} (backward check: {E_r:.4g} without vs {E_full:.4g} with)")
                    for t in trials:
                        if t.kept and cand.name in t.name.split("+"):
                            t.reason = (f"{cand.name} dropped in the backward check: without it held-out NRMSE "
                                        f"{E_r:.4g} vs {E_full:.4g} with it")
                    added = [([c], current, tr) for c in keep for (cs, _, tr) in added if c in cs]
                    current = fr_r
                    current_spec = _with_fit(spec_r, fr_r)
                    removed = True
                    break
        T["search"] = time.perf_counter() - t0 - T["calibrate"]
        flat_added = [(c, fr, tr) for cs, fr, tr in added for c in cs]
        own = None
        if sensor_zero is None and self.spec.position_zero == "nominal" and current.spec.position_zero == "own":
            # the joint explanation of rule (g) was named: a sag-moving parameter with the positions read from
            # the car's own equilibrium
            own = {"offsets": self._offsets_of(current),
                   "with": [t.name for _, _, t in added if t.own_zero],
                   "trials": {t.name: t.own_zero for t in trials if t.own_zero and t.kept}}
            self.log("the positions appear measured from the car's own equilibrium (offsets " + ", ".join(
                f"{c} {1e3 * o:+.2f} mm" for c, o in own["offsets"].items()) + ")")
        D = Diagnosis(self.rec, self.prob, self.test_prob, self.train, self.test, floors, nominal, current,
                      flat_added, trials, sc, T, sensor_zero=sensor_zero, own_equilibrium=own,
                      split=self.split_info)
        if sensor_gain is not None:  # the gains of the final model (the search went on after rule (h))
            D.sensor_gain = {**sensor_gain, **self.gain_finding(current, a, b),
                             "floor_nrmse": {c: float(floors[c]["nrmse"]) for c in self.prob.channels}}
        for c in self.recolour(floors, current):
            self.log(f"noise floor of {c} raised to {floors[c]['value']:.4g}: the final residual is coloured noise")
        floor_n = np.array([floors[c]["nrmse"] for c in self.prob.channels])
        E = float(np.sqrt(np.mean(self._test_errors(current) ** 2)))
        fl = float(np.sqrt(np.mean(floor_n ** 2)))
        if fl > 0 and E > self.far * fl:
            D.unexplained = E / fl
            try:
                from .beyond import propose

                D.proposal = propose(D, current)
            except Exception as err:  # the proposal is advice: never lose the diagnosis over it
                D.proposal = {"error": f"{type(err).__name__}: {err}"}
            if D.proposal:
                self.log(f"beyond the library: {D.proposal.get('equation')}")
        return D


def init_sdof(rec: Record, spec: ModelSpec) -> None:
    """Starting values of free SDOF parameters by equation error: least squares of
    ``m·ẍ + c·ṡ + k·s = gain·u + offset`` with derivatives of the measured position (central differences).
    Only used when mass, stiffness or damping is free and a force input and a position are measured; kept
    only when they simulate better than the given/default values.  (They become the model's nominal values:
    the car is built, and its ride height set, with them.)"""
    free = {f.name: f for f in spec.free}
    names = [n for n in ("sprung_mass", "damping", "spring_stiffness") if n in free]
    if not names or "pos" not in rec.outputs or "force" not in rec.inputs:
        return
    dt = rec.dt
    x = rec.outputs["pos"]
    base = rec.inputs.get("base", np.zeros_like(x))
    acc = np.empty_like(x)
    acc[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) / dt ** 2
    acc[0], acc[-1] = acc[1], acc[-2]
    s = x - base
    sd = np.gradient(s, dt)
    u = rec.inputs["force"]
    cols = {"sprung_mass": acc, "damping": sd, "spring_stiffness": s}
    rhs = u * spec.P.get("input.gain", 1.0) - sum(spec.P[n] * cols[n] for n in cols if n not in free)
    A = np.stack([cols[n] for n in names] + [-np.ones_like(u)], axis=1)
    sol, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    P_eq = dict(spec.P)
    for n, val in zip(names, sol):
        P_eq[n] = abs(val) if n == "sprung_mass" else max(val, 0.0)
    if "input.offset" in free:
        P_eq["input.offset"] = float(sol[-1])
    if not P_eq["sprung_mass"] > 0:
        return
    m = min(len(x), 20000)
    err = []
    for PP in (spec.P, P_eq):
        sp = spec.copy()
        sp.P = dict(PP)
        chk = Problem(rec.slice(0, m), sp)
        err.append(np.mean(list(chk.nrmse(chk.simulate(sp, PP), 0, m).values())))
    if not err[1] < err[0]:
        return
    for n in names:
        spec.P[n] = P_eq[n]
        free[n].init = float(P_eq[n])
        if P_eq[n] > 0:
            free[n].scale = float(P_eq[n])
        if n == "sprung_mass":
            free[n].lo = 1e-6 * P_eq[n]
    if "input.offset" in free:
        free["input.offset"].init = float(sol[-1])
        free["input.offset"].scale = max(float(np.std(u)) * 0.01, 1e-12)
        spec.P["input.offset"] = float(sol[-1])


def _contained(cands) -> list:
    """The free linear parameters the candidates contain (:meth:`Selector._replaced`'s ``contained``; a test
    double without ``contains_free`` contains none)."""
    return [p for c in cands for p in getattr(c, "contains_free", ())]
