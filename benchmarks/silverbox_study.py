"""What the Silverbox fit lacked, one hypothesis at a time (docs/diagnose.md, "Real data").  Two parts:

- ``engine``: the project's own simulator (diagnose's engine), the model the workflow names (SDOF + cubic
  stiffness, m, k, c, k3 and the force offset free), fitted on the first 20 000 training samples and scored on
  the multisine test (first 50 samples unscored), changing one thing at a time: the input hold, the physics
  step, the initial state of the test;
- ``reference``: an independent continuous-time model (own RK4, 4 sub-steps per sample, the input
  reconstructed per hold; fitted on the whole training part), with extra terms beyond the library:
  a quadratic (asymmetric) stiffness k2·y² and quadratic damping cq·v|v|.

    python benchmarks/silverbox_study.py [engine|reference]
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
REAL = REPO.parent / "shared" / "data" / "real"
FS = 1e7 / 2 ** 14
TRAIN, TEST = (40650, 105712), (105712, 127400)


def engine(real: Path = REAL, ntr: int = 20000, log=print) -> list:
    from suspension_sim.diagnose.calibrate import Problem, fit
    from suspension_sim.diagnose.io import load_record
    from suspension_sim.diagnose.model import load_model

    warnings.filterwarnings("ignore")
    f = str(real / "silverbox" / "SNLS80mV.csv")
    kw = dict(mapping={"V1": ("force", 1.0), "V2": ("pos", 1.0)}, fs=FS)
    model = {"model": "sdof", "params": {"sprung_mass": {"value": 5.2e-06, "free": True},
                                         "spring_stiffness": {"value": 0.96, "free": True},
                                         "damping": {"value": 2.2e-4, "free": True}},
             "effects": [{"type": "cubic_stiffness", "params": {"k3": {"value": 3.8, "free": True}}}],
             "inputs": {"force_offset": {"value": -5.4e-3, "free": True}}}
    rows = []
    for label, hold, max_dt, init in (("linear hold (before)", "linear", 5e-4, False),
                                      ("band-limited hold", "bandlimited", 5e-4, False),
                                      ("+ half the physics step (0.2 ms)", "bandlimited", 2.5e-4, False),
                                      ("band-limited, test state from its first 50 samples", "bandlimited", 5e-4, True)):
        spec = load_model(model)
        rec = load_record(f, "sdof", rows=(TRAIN[0], TRAIN[0] + ntr), hold=hold, **kw)
        trec = load_record(f, "sdof", rows=TEST, hold=hold, **kw)
        fr = fit(Problem(rec, spec, max_dt=max_dt), spec, 0, len(rec), max_nfev=60)
        tp = Problem(trec, spec, skip=50, max_dt=max_dt)
        if not init:  # from rest (the engine before the initial-state estimate)
            tp.skip = 0
            sim = tp.simulate(spec, fr.P)
            tp.skip = 50
        else:
            sim = tp.simulate(spec, fr.P)
        mv = 1e3 * tp.rmse(sim, 0, len(trec), offsets=np.zeros(1))["pos"]
        rows.append({"change": label, "multisine_mV": mv, "fitted": fr.params})
        log(f"{label:<55s} multisine {mv:.3f} mV   {fr.params}")
    return rows


def reference(real: Path = REAL, log=print) -> list:
    import numba
    import pandas as pd
    from scipy.optimize import least_squares

    from suspension_sim.diagnose.datafile import reconstruct

    d = pd.read_csv(real / "silverbox" / "SNLS80mV.csv", usecols=[0, 1]).to_numpy()
    U, Y = d[:, 0].copy(), d[:, 1].copy()
    T, sub = 1 / FS, 4

    @numba.njit(cache=False)
    def sim(uf, n, h, p, x0, v0, out):
        g, cm, km, k3m, o, k2m, cqm = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
        x, v = x0, v0
        ns = (uf.shape[0] - 1) // 2 // n if n > 0 else 0
        for k in range(n):
            out[k] = x
            for j in range(ns):
                i0 = 2 * (k * ns + j)
                a1 = g * (uf[i0] + o) - cm * v - km * x - k3m * x ** 3 - k2m * x * x - cqm * v * abs(v)
                x2, v2 = x + 0.5 * h * v, v + 0.5 * h * a1
                a2 = g * (uf[i0 + 1] + o) - cm * v2 - km * x2 - k3m * x2 ** 3 - k2m * x2 * x2 - cqm * v2 * abs(v2)
                x3, v3 = x + 0.5 * h * v2, v + 0.5 * h * a2
                a3 = g * (uf[i0 + 1] + o) - cm * v3 - km * x3 - k3m * x3 ** 3 - k2m * x3 * x3 - cqm * v3 * abs(v3)
                x4, v4 = x + h * v3, v + h * a3
                a4 = g * (uf[i0 + 2] + o) - cm * v4 - km * x4 - k3m * x4 ** 3 - k2m * x4 * x4 - cqm * v4 * abs(v4)
                x += h / 6 * (v + 2 * v2 + 2 * v3 + v4)
                v += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)

    def run(uf_all, a, n, p, x0, v0):
        uf = uf_all[2 * sub * a: 2 * sub * (a + n) + 1]
        out = np.empty(n)
        sim(uf, n, T / sub, p, x0, v0, out)
        return out

    m0 = 5.376e-6
    P0 = np.array([1 / m0, 2.25e-4 / m0, 0.99 / m0, 3.9 / m0, -5.4e-3, 0.0, 0.0])
    sc = np.abs(P0) + np.array([0, 0, 0, 0, 0, 1e-2 / m0, 1e-7 / m0])
    rows = []
    for hold, extra in (("linear", ()), ("zoh", ()), ("bandlimited", ()), ("bandlimited", ("k2",)),
                        ("bandlimited", ("cq",)), ("bandlimited", ("k2", "cq"))):
        tq = np.arange(2 * sub * len(U) + 1) * (T / (2 * sub))
        uf_all = reconstruct(U, T, tq + (0.5 * T if hold == "zoh" else 0.0), hold)  # zoh: centred on the samples

        def unpack(z):
            p = z * sc
            p[5] = p[5] if "k2" in extra else 0.0
            p[6] = p[6] if "cq" in extra else 0.0
            return p

        a, b = TRAIN
        res = lambda z: (run(uf_all, a, b - a, unpack(z), Y[a], 0.0) - Y[a:b])[50:]  # noqa: E731
        p = unpack(least_squares(res, P0 / sc, x_scale="jac", max_nfev=200).x)
        ta, tb = TEST
        s0 = least_squares(lambda s: run(uf_all, ta, 50, p, s[0], s[1]) - Y[ta:ta + 50], [Y[ta], 0.0],
                           x_scale=[1e-2, 1.0]).x
        e = (run(uf_all, ta, tb - ta, p, s0[0], s0[1]) - Y[ta:tb])[50:]
        mv = 1e3 * float(np.sqrt(np.mean(e ** 2)))
        m = 1 / p[0]
        rows.append({"hold": hold, "extra": list(extra), "multisine_mV": mv, "f0_Hz": float(np.sqrt(p[2]) / 2 / np.pi),
                     "k3": p[3] * m, "k2": p[5] * m, "cq": p[6] * m})
        log(f"{hold:<12s} {'+'.join(('cubic',) + extra):<12s} multisine {mv:.3f} mV  f0 {rows[-1]['f0_Hz']:.2f} Hz  "
            f"k3 {p[3] * m:.3f}  k2 {p[5] * m:.4g}  cq {p[6] * m:.4g}")
    return rows


if __name__ == "__main__":
    {"engine": engine, "reference": reference}[sys.argv[1] if len(sys.argv) > 1 else "reference"]()
