"""Greedy forward selection of missing effects.

1. Calibrate the nominal model's free parameters on the training part.
2. For every applicable candidate: add it, refit (the candidate's parameters and every free parameter,
   from several starts), and score it on the training data by BIC (N·ln(cost) + p·ln N; AIC is reported too).
3. A candidate is *kept* only if, on the held-out data, it lowers the error beyond the noise:
   (a) its BIC is below the current model's, (b) the drop of the squared error on held-out data is
   significant (z > 2 over 20 contiguous blocks, so that correlated residuals are not counted as
   independent; or, for effects that act rarely and concentrate their gain in a few blocks, the candidate
   removes at least half of the held-out error above the noise floor), (c) it removes at least ``min_excess_drop`` (default 10 %) of the held-out error that
   lies *above the noise floor* (``sqrt(NRMSE² − floor²)``; the floor is the sensor noise estimated from the
   data, or a repeatability floor given by the user), and (d) the held-out NRMSE falls by at least
   ``min_rel_drop`` (default 5 %), so that a model already near the floor is not decorated with
   effects that only polish the last digits.
4. Of the kept candidates the one with the lowest BIC is added; repeat from 2 (so two or more effects can
   be found); stop when no candidate is kept.  When none is kept at the first round, nothing is named.
5. Backward check: an added effect is dropped again when the model refitted without it is not worse by BIC
   and its held-out NRMSE is within ``min_rel_drop`` of the full model's (greedy selection can pick a
   stand-in first, e.g. a bump stop for a hardening spring, and keep it after the true effect joins).

Speed: when the training part is longer than 1.5 × ``screen_samples`` (default 20 000: 20 s at 1 kHz),
the screening fits use its first ``screen_samples`` samples and the chosen candidate is refitted on the
whole training part.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import welch

from . import fastsim as fs
from .calibrate import FitResult, Problem, fit
from .candidates import Candidate, Scales, WrongParameter, library
from .io import Record
from .model import ModelSpec


def noise_floor(y: np.ndarray, fs_hz: float) -> float:
    """Sensor-noise standard deviation estimated from the data: the median PSD level in the top band
    (60–95 % of Nyquist), where the dynamics have rolled off, taken as white over the whole band."""
    f, p = welch(y - np.mean(y), fs=fs_hz, nperseg=min(len(y), 1024))
    band = (f > 0.6 * fs_hz / 2) & (f < 0.95 * fs_hz / 2)
    if not band.any():
        return 0.0
    return float(np.sqrt(np.median(p[band]) * fs_hz / 2))


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
    kept: bool = False
    seconds: float = 0.0

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

    def sims(self, fitres: FitResult):
        """(train/whole-record simulation, test simulation) of a fit."""
        s = self.prob.simulate(fitres.P)
        st = self.test_prob.simulate(_for_test(fitres.P)) if self.test_prob is not None else s
        return s, st

    def nrmse(self, fitres: FitResult) -> dict:
        s, st = self.sims(fitres)
        tp = self.test_prob or self.prob
        return {"train": self.prob.nrmse(s, *self.train), "test": tp.nrmse(st, *self.test)}

    def rmse(self, fitres: FitResult) -> dict:
        s, st = self.sims(fitres)
        tp = self.test_prob or self.prob
        return {"train": self.prob.rmse(s, *self.train), "test": tp.rmse(st, *self.test)}


def _for_test(P):
    """Parameters for a separate held-out record: its own initial state, no training-record corrections."""
    P = P.copy()
    P[fs.DX0:fs.DX0 + 4] = 0.0
    return P


def _scales(prob: Problem, P: np.ndarray, b: int) -> Scales:
    out = fs.run(prob.kind, P, {k: v[:b] for k, v in prob.inputs.items()}, prob.dt, prob.nsub, prob.x0)
    if prob.kind == "quarter_car":
        s = out[:, 2]
        ft = out[:, 5]
        tension = bool(np.any((P[fs.MS] + P[fs.MU]) * fs.G + ft < 0))
    elif prob.kind == "half_car":
        # both corners' travels pooled (the effects are shared by the corners)
        s = np.concatenate([out[:, 2] - np.mean(out[:, 2]), out[:, 8] - np.mean(out[:, 8])])
        L = P[fs.HA] + P[fs.HB]
        tension = bool(np.any((P[fs.MS] * P[fs.HB] / L + P[fs.MU]) * fs.G + out[:, 5] < 0)
                       or np.any((P[fs.MS] * P[fs.HA] / L + P[fs.MU_R]) * fs.G + out[:, 11] < 0))
    elif prob.kind == "sdof":
        s = out[:, 2] - prob.inputs["road"][:b]
        tension = False
    else:
        s = prob.inputs["road"][:b]
        tension = False
    s = s - np.mean(s) if prob.kind != "damper" else s
    if prob.kind == "half_car":
        v = np.concatenate([np.gradient(s[:b], prob.dt), np.gradient(s[b:], prob.dt)])
    else:
        v = np.gradient(s, prob.dt) if prob.kind != "damper" else prob.inputs["roaddot"][:b]
    F = P[fs.K] * s + P[fs.C] * v
    Fr = float(np.sqrt(np.mean(F ** 2)))
    if Fr <= 0 and prob.has_force:
        Fr = float(np.std(prob.inputs["force"][:b]))
    return Scales(float(np.sqrt(np.mean(s ** 2))) or 1e-6, float(np.max(np.abs(s))) or 1e-6,
                  float(np.sqrt(np.mean(v ** 2))) or 1e-6, Fr or 1.0, float(P[fs.K]), float(P[fs.C]),
                  prob.has_force, tension, m_red=_m_red(prob.kind, P), h=prob.dt / prob.nsub)


def _m_red(kind, P):
    if kind == "half_car":
        m = 0.5 * P[fs.MS]
        return float(min(m * P[fs.MU] / (m + P[fs.MU]), m * P[fs.MU_R] / (m + P[fs.MU_R])))
    if kind == "quarter_car":
        return float(P[fs.MS] * P[fs.MU] / (P[fs.MS] + P[fs.MU]))
    return float(P[fs.MS]) if kind == "sdof" else float("inf")


def _with_fit(spec: ModelSpec, fr: FitResult) -> ModelSpec:
    """``spec`` with its parameter vector and starting values at a fit's optimum."""
    s = spec.copy()
    s.P = fr.P.copy()
    for f, v in zip(s.free, fr.x):
        f.init = float(v)
    return s


def _augment(spec: ModelSpec, cand: Candidate, sc: Scales) -> tuple[ModelSpec, list[np.ndarray]]:
    s = spec.copy()
    cand.setup(s.P, sc)
    if isinstance(cand, WrongParameter):
        s.free = s.free + cand.free_for(s.P)
        s.fixed_nominal = [p for p in s.fixed_nominal if p != cand.pname]
        return s, [s.x0]
    new = cand.free(sc)
    s.free = s.free + new
    s.effects = s.effects + [cand.name]
    base = [f.init for f in spec.free]
    starts = [np.array(base + list(st), float) for st in cand.starts(sc)] if new else [s.x0]
    return s, starts


def init_sdof(rec: Record, spec: ModelSpec) -> None:
    """Starting values of free SDOF parameters by equation error: least squares of
    ``m·ẍ + c·ṡ + k·s = u + offset`` with derivatives of the measured position (central differences).
    Only used when mass, stiffness or damping is free and a force input and a position are measured."""
    free = {f.name: f for f in spec.free}
    if not ({"sprung_mass", "spring_stiffness", "damping"} & set(free)) or "pos" not in rec.outputs \
            or "force" not in rec.inputs:
        return
    dt = rec.dt
    x = rec.outputs["pos"]
    base = rec.inputs.get("base", np.zeros_like(x))
    # three-point second difference: less high-frequency bias than differentiating twice with 2·dt spacing
    acc = np.empty_like(x)
    acc[1:-1] = (x[2:] - 2 * x[1:-1] + x[:-2]) / dt ** 2
    acc[0], acc[-1] = acc[1], acc[-2]
    s = x - base
    sd = np.gradient(s, dt)
    u = rec.inputs["force"]
    cols = {"sprung_mass": acc, "damping": sd, "spring_stiffness": s}
    names = [n for n in ("sprung_mass", "damping", "spring_stiffness") if n in free]
    rhs = u * spec.P[fs.GAIN] - sum(spec.P[{"sprung_mass": fs.MS, "damping": fs.C, "spring_stiffness": fs.K}[n]] * cols[n]
                                   for n in cols if n not in free)
    A = np.stack([cols[n] for n in names] + [-np.ones_like(u)], axis=1)
    sol, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    slot_of = {"sprung_mass": fs.MS, "damping": fs.C, "spring_stiffness": fs.K}
    P_eq = spec.P.copy()
    for n, val in zip(names, sol):
        P_eq[slot_of[n]] = abs(val) if n == "sprung_mass" else max(val, 0.0)
    if "force_offset" in free:
        P_eq[fs.OFFS] = float(sol[-1])
    # keep the equation-error values only if they simulate better than the given/default starting values
    m = min(len(x), 20000)
    chk = Problem(rec.slice(0, m), omega_max=max(Problem.omega_max(spec), _omega(P_eq, spec.kind)))
    err = [np.mean(list(chk.nrmse(chk.simulate(PP), 0, m).values())) for PP in (spec.P, P_eq)]
    if not (err[1] < err[0]) or P_eq[fs.MS] <= 0:
        return
    for n in names:
        slot = slot_of[n]
        spec.P[slot] = P_eq[slot]
        free[n].init = float(P_eq[slot])
        if P_eq[slot] > 0:
            free[n].scale = float(P_eq[slot])
        if n == "sprung_mass":
            free[n].lo = 1e-6 * P_eq[slot]
    if "force_offset" in free:
        free["force_offset"].init = float(sol[-1])
        free["force_offset"].scale = max(float(np.std(u)) * 0.01, 1e-12)
        spec.P[fs.OFFS] = float(sol[-1])


def _omega(P, kind):
    return float(np.sqrt(max(P[fs.K], 0) / P[fs.MS])) if P[fs.MS] > 0 else 0.0


class Selector:
    def __init__(self, rec: Record, spec: ModelSpec, split: float = 0.7, test_record: Record | None = None,
                 floors: dict | None = None, candidates: list[str] | None = None, max_effects: int = 3,
                 screen_samples: int = 20000, min_excess_drop: float = 0.10, z_min: float = 2.0,
                 min_rel_drop: float = 0.05,
                 test_skip: int | None = None, log=None, workers: int | None = None, max_substep: float = 1e-3):
        import os

        self.rec = rec
        self.spec = spec
        self.workers = workers or min(2, os.cpu_count() or 1)
        if rec.kind == "sdof":
            init_sdof(rec, spec)
        om = Problem.omega_max(spec)
        self.prob = Problem(rec, max_substep=max_substep, omega_max=om)
        n = len(rec)
        if test_record is not None:
            self.train = (0, n)
            self.test_prob = Problem(test_record, skip=50 if test_skip is None else test_skip, max_substep=max_substep,
                                     omega_max=om)
            self.test = (0, len(test_record))
        else:
            if not 0.05 < split < 0.95:
                raise ValueError("split must be between 0.05 and 0.95")
            b = int(round(split * n))
            self.train, self.test = (0, b), (b, n)
            self.test_prob = None
        if not self.prob.has_force:
            self.spec.free = [f for f in self.spec.free if not f.name.startswith("force_")]
            self.spec.P[fs.OFFS] = 0.0
        # nuisance: corrections to the measured initial state of lightly damped/integrating models
        from .model import FreeParam

        o = rec.outputs
        if rec.kind == "sdof":
            sp = float(np.std(o["pos"])) if "pos" in o else 0.0
            if sp > 0:
                vs = sp / rec.dt / 50
                self.spec.free += [FreeParam("initial.pos", fs.DX0, 0.0, -np.inf, np.inf, 0.01 * sp),
                                   FreeParam("initial.vel", fs.DX0 + 1, 0.0, -np.inf, np.inf, vs)]
        elif rec.kind == "quarter_car" and "body_pos" in o and "wheel_pos" in o:
            for k, ch in ((0, "body_pos"), (2, "wheel_pos")):
                sp = float(np.std(o[ch]))
                self.spec.free += [FreeParam(f"initial.{ch}", fs.DX0 + k, 0.0, -np.inf, np.inf, 0.01 * sp),
                                   FreeParam(f"initial.{ch}_rate", fs.DX0 + k + 1, 0.0, -np.inf, np.inf, sp / rec.dt / 50)]
        self.user_floors = floors or {}
        self.cand_filter = candidates
        self.max_effects = max_effects
        self.screen = screen_samples
        self.min_excess_drop = min_excess_drop
        self.min_rel_drop = min_rel_drop
        self.z_min = z_min
        self.log = log or (lambda msg: None)

    # --------------------------------------------------------------------------------------------------
    def floors(self) -> dict:
        """Noise floor per channel (in channel units): the user's value or the estimate from the data."""
        out = {}
        for i, c in enumerate(self.prob.channels):
            if c in self.user_floors:
                out[c] = {"value": float(self.user_floors[c]), "source": "user (repeatability)"}
            else:
                out[c] = {"value": noise_floor(self.prob.Y[:, i], self.rec.fs), "source": "estimated (PSD top band)"}
            out[c]["nrmse"] = out[c]["value"] / float(self.prob.scale[i])
        return out

    def _test_errors(self, P):
        tp = self.test_prob or self.prob
        sim = tp.simulate(_for_test(P) if self.test_prob is not None else P)
        a, b = self.test
        a = max(a, tp.skip)
        e = (sim[a:b] - tp.Y[a:b]) / tp.scale
        return e

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

    # --------------------------------------------------------------------------------------------------
    def run(self) -> Diagnosis:
        import time

        T = {}
        t0 = time.perf_counter()
        floors = self.floors()
        floor_n = np.array([floors[c]["nrmse"] for c in self.prob.channels])
        a, b = self.train
        self.log(f"calibrating the nominal model ({', '.join(self.spec.names()) or 'nothing free'}) on "
                 f"{b - a} training samples")
        # screening window: the whole training part unless it is much longer than screen_samples
        bs = b if b - a <= 1.5 * self.screen else a + self.screen
        nominal = fit(self.prob, self.spec, a, bs, max_nfev=100)
        if bs < b:  # polish on the whole training part from the screening optimum
            nominal = fit(self.prob, _with_fit(self.spec, nominal), a, b, max_nfev=30)
        T["calibrate"] = time.perf_counter() - t0
        current_spec = _with_fit(self.spec, nominal)
        current = nominal
        sc = _scales(self.prob, nominal.P, b)
        if self.rec.kind in ("quarter_car", "half_car"):  # tire tension anywhere in the record (inputs are known throughout)
            sc.tire_tension = _scales(self.prob, nominal.P, len(self.rec)).tire_tension or (
                self.test_prob is not None and _scales(self.test_prob, _for_test(nominal.P), len(self.test_prob.rec)).tire_tension)
        cur_screen = fit(self.prob, current_spec, a, bs, max_nfev=1) if bs < b else current
        lib = library(self.rec.kind)
        if self.cand_filter is not None:
            lib = [c for c in lib if c.name in self.cand_filter or (c.name.startswith("parameter:")
                                                                     and "parameter" in self.cand_filter)]
        added, trials = [], []
        e_cur = self._test_errors(current.P)
        for rnd in range(1, self.max_effects + 1):
            best = None
            todo = []
            prev = {t.name: t for t in trials if t.round == rnd - 1}
            for cand in lib:
                if any(c.name == cand.name for c, _, _ in added):
                    continue
                ok, why = cand.applies(self.rec.kind, sc, current_spec)
                pt = prev.get(cand.name)
                if ok and pt is not None and pt.applicable and np.isfinite(pt.d_bic) and pt.d_bic >= 0:
                    ok, why = False, f"pruned: no training improvement in round {rnd - 1} (ΔBIC {pt.d_bic:+.1f})"
                tr = Trial(cand.name, rnd, ok, why)
                trials.append(tr)
                if ok:
                    todo.append((cand, tr))

            def attempt(item, current_spec=current_spec, current=current, cur_screen=cur_screen, e_cur=e_cur):
                cand, tr = item
                t1 = time.perf_counter()
                spec_c, starts = _augment(current_spec, cand, sc)
                try:
                    fr = fit(self.prob, spec_c, a, bs, starts=starts, max_nfev=25)
                except RuntimeError as err:
                    tr.applicable, tr.reason = False, f"fit failed: {err}"
                    return None
                e_new = self._test_errors(fr.P)
                Eb, Ea, xb, xa, z = self._gate(e_cur, e_new, floor_n)
                tr.params = {k: v for k, v in fr.params.items() if k not in current.params}
                tr.bic, tr.aic = fr.bic(), fr.aic()
                tr.d_bic = fr.bic() - cur_screen.bic()
                tr.test_before, tr.test_after, tr.excess_before, tr.excess_after, tr.z = Eb, Ea, xb, xa, z
                # significance: z over blocks, or (for effects that act rarely, whose gain sits in a few
                # blocks) a large gain that removes at least half of the held-out error above the floor
                signif = z > self.z_min or xa <= 0.5 * xb
                tr.kept = bool(tr.d_bic < 0 and signif and xa <= (1 - self.min_excess_drop) * xb
                               and Ea <= (1 - self.min_rel_drop) * Eb)
                tr.seconds = time.perf_counter() - t1
                return cand, spec_c, tr, fr

            self.prob.parallel = self.workers <= 1
            if self.workers > 1:
                from concurrent.futures import ThreadPoolExecutor

                with ThreadPoolExecutor(self.workers) as ex:
                    results = list(ex.map(attempt, todo))
            else:
                results = [attempt(it) for it in todo]
            self.prob.parallel = True
            for res in results:
                if res is None:
                    continue
                cand, spec_c, tr, fr = res
                self.log(f"  round {rnd} {cand.name:<28} ΔBIC {tr.d_bic:12.1f}  test NRMSE {tr.test_before:.4f} → "
                         f"{tr.test_after:.4f}  z {tr.z:6.1f}  {tr.seconds:5.1f} s  {'KEPT' if tr.kept else ''}")
                if tr.kept and (best is None or tr.bic < best[2].bic):
                    best = res
            if best is None:
                break
            cand, spec_c, tr, fr = best
            # polish on the whole training part, so that the next round starts from the optimum
            fr = fit(self.prob, _with_fit(spec_c, fr), a, bs, max_nfev=100)
            if bs < b:
                fr = fit(self.prob, _with_fit(spec_c, fr), a, b, max_nfev=30)
            added.append((cand, fr, tr))
            current_spec = _with_fit(spec_c, fr)
            current = fr
            cur_screen = fit(self.prob, current_spec, a, bs, max_nfev=1) if bs < b else current
            e_cur = self._test_errors(current.P)
            self.log(f"added {cand.name}: {fr.params}")
        # backward check: greedy forward selection can pick a stand-in first (e.g. a bump stop for a hardening
        # spring) and keep it after the real effect joins; drop an added effect when the model without it is
        # as good on held-out data (its removal raises the held-out NRMSE by less than min_rel_drop) and not
        # worse by BIC on the training data
        removed = True
        while removed and len(added) >= 2:
            removed = False
            e_full = self._test_errors(current.P)
            E_full = float(np.sqrt(np.mean(e_full ** 2)))
            for k in range(len(added)):
                keep = [x for i, x in enumerate(added) if i != k]
                spec_r = _with_fit(self.spec, nominal)
                starts_ok = True
                for cand, _, _ in keep:
                    spec_r, _st = _augment(spec_r, cand, sc)
                # start every parameter from the full model's values
                vals = current.params
                for f in spec_r.free:
                    if f.name in vals:
                        f.init = vals[f.name]
                try:
                    fr_r = fit(self.prob, spec_r, a, b, max_nfev=60)
                except RuntimeError:
                    starts_ok = False
                if not starts_ok:
                    continue
                E_r = float(np.sqrt(np.mean(self._test_errors(fr_r.P) ** 2)))
                if E_r <= E_full / (1 - self.min_rel_drop) and fr_r.bic() <= current.bic():
                    cand, _, tr = added[k]
                    tr.kept = False
                    tr.reason = (f"dropped in the backward check: without it held-out NRMSE {E_r:.4g} vs "
                                 f"{E_full:.4g} with it")
                    self.log(f"dropped {cand.name} (backward check: {E_r:.4g} without vs {E_full:.4g} with)")
                    added = keep
                    current = fr_r
                    current_spec = _with_fit(spec_r, fr_r)
                    removed = True
                    break
        T["search"] = time.perf_counter() - t0 - T["calibrate"]
        final = current
        return Diagnosis(self.rec, self.prob, self.test_prob, self.train, self.test, floors, nominal, final, added,
                         trials, sc, T)
