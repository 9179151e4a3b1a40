"""Frequency-domain plots against a reference model (the thesis's Figs. 3.12–3.16, 4.10–4.12, 5.x, 6.3–6.6):
system gain factors |H(f)| of a response with respect to the road input, and power spectral densities,
each run overlaid with the reference model's response logged by the adaptive controllers
(``ctrl.ref_x``, ``ctrl.ref_acc``, ``ctrl.ref_travel``, ``ctrl.ref_z[.k]``, ``ctrl.ref_pitch``).

:func:`frequency_pairs` finds the (response, reference) channel pairs a run has; :func:`gain_factor` is the
H1 estimate |S_wy|/S_ww (Welch, scipy.signal.csd/welch) over the part of the run after ``t_skip`` (the
adaptation transient); :func:`plot_frequency` writes ``gain_factors.png`` and ``psd_reference.png``
into a run folder (only when some run logs a reference model, so ordinary runs keep their standard
plots).  Runs without a varying road (a flat road, a manoeuvre) get no frequency plots: a
gain factor needs an input with spectral content.  Called from :func:`suspension_sim.plots.plot_run`.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy import signal

# (label, response channel, reference channel, unit)
_CANDIDATES = [
    ("body displacement", "body_z", "ctrl.ref_x", "m"),
    ("body displacement", "body_z", "ctrl.ref_z", "m"),
    ("body acceleration", "body_acc", "ctrl.ref_acc", "m/s²"),
    ("pitch", "pitch", "ctrl.ref_pitch", "rad"),
    ("relative displacement", "travel", "ctrl.ref_travel", "m"),
    ("secondary rattle space", "travel_secondary", "ctrl.ref_z.0", "m"),
    ("primary rattle space", "travel_primary", "ctrl.ref_z.1", "m"),
]


def _road_channel(ts) -> str | None:
    for c in ("road", "road_front", "road_primary"):
        if c in ts.columns:
            return c
    return None


def frequency_pairs(results: dict, require_reference: bool = True) -> list[tuple[str, str, str | None, str]]:
    """(label, response, reference or None, unit) available in the runs (reference: first run that has it).
    Without a reference channel: none, or with ``require_reference=False`` the body displacement and
    acceleration gain factors alone."""
    out = []
    seen = set()
    for label, ch, ref, unit in _CANDIDATES:
        if ch in seen:
            continue
        have_ch = any(ch in r.ts.columns for r in results.values())
        have_ref = any(ref in r.ts.columns for r in results.values())
        if have_ch and have_ref:
            out.append((label, ch, ref, unit))
            seen.add(ch)
    if not out and not require_reference:  # no reference: the body displacement and acceleration alone
        for label, ch, unit in (("body displacement", "body_z", "m"), ("body acceleration", "body_acc", "m/s²")):
            if any(ch in r.ts.columns for r in results.values()):
                out.append((label, ch, None, unit))
    return out


def _fs(ts) -> float:
    t = ts["t"].to_numpy()
    return 1.0 / float(np.median(np.diff(t)))


def _segment(n: int, fs: float, resolution: float) -> int:
    return int(min(n, 2 ** int(np.ceil(np.log2(fs / resolution)))))


def psd(x, fs: float, resolution: float = 0.05):
    x = np.asarray(x, dtype=float)
    return signal.welch(x - x.mean(), fs=fs, nperseg=_segment(len(x), fs, resolution))


def gain_factor(u, y, fs: float, resolution: float = 0.05):
    """H1 gain factor |S_uy(f)|/S_uu(f) of response y to input u (Welch segments)."""
    u = np.asarray(u, dtype=float) - np.mean(u)
    y = np.asarray(y, dtype=float) - np.mean(y)
    nps = _segment(len(u), fs, resolution)
    f, Suu = signal.welch(u, fs=fs, nperseg=nps)
    _, Suy = signal.csd(u, y, fs=fs, nperseg=nps)
    return f, np.abs(Suy) / np.maximum(Suu, 1e-30)


def _input_for(ch: str, ts, road: str):
    """The road signal matching the response: displacement-like responses against the road height, the
    acceleration against the road acceleration (the thesis's acceleration transmissibility)."""
    w = ts[road].to_numpy()
    if ch == "body_acc":
        vel = f"{road.replace('road', 'road_vel')}"
        fs = _fs(ts)
        if vel in ts.columns:
            return np.gradient(ts[vel].to_numpy(), 1.0 / fs)
        return np.gradient(np.gradient(w, 1.0 / fs), 1.0 / fs)
    return w


def plot_frequency(results, out_dir, t_skip: float | None = None, fmax: float = 20.0,
                   require_reference: bool = True) -> list[Path]:
    """Write ``gain_factors.png`` and ``psd_reference.png`` for ``results`` ({label: Result}); returns the
    paths (none for runs without a varying road, and — unless ``require_reference=False`` — none for runs
    without a controller that logs a reference model).  ``t_skip``: seconds dropped at the start (default:
    a quarter of the run, at most 10 s)."""
    if hasattr(results, "timeseries"):
        results = {getattr(results.scenario, "name", "run"): results}
    from .results import previewed

    results = {k: previewed(r) for k, r in dict(results).items()}
    out_dir = Path(out_dir)
    runs = {}
    for k, r in results.items():
        ts = r.ts
        road = _road_channel(ts)
        if road is None or np.nanstd(ts[road].to_numpy()) < 1e-6 or len(ts) < 64:
            continue
        skip = t_skip if t_skip is not None else min(10.0, 0.25 * float(ts["t"].iloc[-1]))
        runs[k] = (ts[ts["t"] >= skip].reset_index(drop=True), road)
    if not runs:
        return []
    pairs = frequency_pairs({k: results[k] for k in runs}, require_reference)
    if not pairs:
        return []
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for kind in ("gain", "psd"):
        fig = Figure(figsize=(10, 2.6 * len(pairs)), dpi=110)
        FigureCanvasAgg(fig)
        axes = fig.subplots(len(pairs), 1, squeeze=False)[:, 0]
        for ax, (label, ch, ref, unit) in zip(axes, pairs):
            ref_done = False
            shown: list[np.ndarray] = []
            for i, (k, (ts, road)) in enumerate(runs.items()):
                if ch not in ts.columns:
                    continue
                fs = _fs(ts)
                u = _input_for(ch, ts, road)
                if kind == "gain":
                    f, H = gain_factor(u, ts[ch].to_numpy(), fs)
                else:
                    f, H = psd(ts[ch].to_numpy(), fs)
                ax.loglog(f[1:], H[1:], lw=1.0, label=k)
                shown.append(H[(f >= 0.1) & (f <= fmax)])
                if ref is not None and ref in ts.columns and not ref_done:
                    f, H = gain_factor(u, ts[ref].to_numpy(), fs) if kind == "gain" else psd(ts[ref].to_numpy(), fs)
                    ax.loglog(f[1:], H[1:], "k--", lw=1.2, label="reference model")
                    shown.append(H[(f >= 0.1) & (f <= fmax)])
                    ref_done = True
            ax.set_xlim(0.1, fmax)
            vals = np.concatenate(shown) if shown else np.array([])
            vals = vals[np.isfinite(vals) & (vals > 0)]
            if vals.size:
                ax.set_ylim(0.5 * np.percentile(vals, 0.5), 2.0 * vals.max())
            ax.grid(True, which="both", alpha=0.3)
            if kind == "gain":
                ax.set_ylabel("gain factor (–)" if ch != "pitch" else "gain (rad/m)")
                ax.set_title(f"System gain factor: {label} / road input", fontsize=9)
            else:
                ax.set_ylabel(f"PSD ({unit}²/Hz)")
                ax.set_title(f"PSD: {label}", fontsize=9)
            ax.legend(fontsize=7, loc="best")
        axes[-1].set_xlabel("frequency (Hz)")
        fig.tight_layout()
        path = out_dir / ("gain_factors.png" if kind == "gain" else "psd_reference.png")
        fig.savefig(path)
        written.append(path)
    return written
