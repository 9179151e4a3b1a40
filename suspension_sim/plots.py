"""Plots of one or more runs (PNG, matplotlib's Agg renderer).

:func:`plot_run` takes ``{label: Result}`` (e.g. the variants ``passive`` and ``skyhook`` of one scenario)
and writes into ``out_dir``, one line per run so the runs overlay, one subplot per corner:

- ``body_acceleration.png``  body heave acceleration at the c.g. (m/s²), with the ISO 2631-1 Wk RMS;
- ``body_acc_psd.png``       Welch PSD of the body acceleration, unweighted and Wk-weighted (log-log);
- ``suspension_travel.png``  travel per corner (mm, + = extension), bump-stop gaps dashed if set;
- ``tire_load.png``          dynamic tire load per corner (N, + = more compression), lift-off level dashed
  when a run comes near it;
- ``actuator_force.png``     delivered actuator force per corner (N, + = body up / wheel down);
- ``attitude.png``           pitch and roll angles (deg), for models that have them.

A figure whose channel no run has is skipped.  The figures are built with :class:`matplotlib.figure.Figure`
and the Agg canvas directly, so this neither needs a display nor changes the pyplot backend of a session that
imports it.  :func:`plot_psd_comparison` draws the PSD panel on its own (or onto given axes) for studies.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy import signal

DPI = 110
_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
           "#bcbd22", "#17becf"]


# --------------------------------------------------------------------------------------------------- helpers
def _as_dict(results) -> dict:
    if isinstance(results, Mapping):
        out = dict(results)
    elif hasattr(results, "timeseries"):
        out = {_name(results, "run"): results}
    else:
        out = {_name(r, f"run {i + 1}"): r for i, r in enumerate(results)}
    from .results import previewed

    return {k: previewed(r) for k, r in out.items()}


def _name(r, default: str) -> str:
    sc = getattr(r, "scenario", None)
    return getattr(sc, "name", None) or default


def _title_suffix(results: dict) -> str:
    names = {_name(r, "").split("/")[0] for r in results.values()}
    names.discard("")
    return f" — {names.pop()}" if len(names) == 1 else ""


def _corners(results: dict) -> list[tuple[str, str]]:
    """(suffix, display name) of the corners, from the first run's info (one corner '' if unknown)."""
    info = next(iter(results.values())).info or {}
    sfx = list(info.get("suffixes", [""]))
    names = list(info.get("corners", []))
    out = []
    for k, s in enumerate(sfx):
        nm = names[k] if k < len(names) and names[k] not in ("single", "") else s.lstrip("_")
        out.append((s, nm))
    return out


def _fig(nrows: int, ncols: int = 1, height: float = 2.5, width: float = 10.0):
    fig = Figure(figsize=(width, 1.0 + height * nrows), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=True, squeeze=False)
    return fig, axes[:, 0] if ncols == 1 else axes


def _style(ax, ylabel: str, xlabel: str | None = None, title: str | None = None):
    ax.set_ylabel(ylabel)
    if xlabel:
        ax.set_xlabel(xlabel)
    if title:
        ax.set_title(title, fontsize=10, loc="left")
    ax.grid(True, alpha=0.3)


def _legend(ax, n: int):
    if n > 1 or ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8, loc="upper right", framealpha=0.85)


def _save(fig, path: Path) -> Path:
    fig.savefig(path)
    return path


def _fs(ts) -> float:
    t = ts["t"].to_numpy()
    return 1.0 / float(t[1] - t[0]) if len(t) > 1 else float("nan")


def _colors(results: dict) -> dict:
    return {k: _COLORS[i % len(_COLORS)] for i, k in enumerate(results)}


def _time_series(results, out_dir: Path, fname: str, title: str, base: str, ylabel: str, scale: float = 1.0,
                 per_corner: bool = True, decorate=None) -> Path | None:
    corners = _corners(results) if per_corner else [("", "")]
    have = [(k, r) for k, r in results.items() if any(f"{base}{s}" in r.ts for s, _ in corners)]
    if not have:
        return None
    col = _colors(results)
    fig, axes = _fig(len(corners))
    for ax, (s, cname) in zip(axes, corners):
        ch = f"{base}{s}"
        for k, r in have:
            if ch in r.ts:
                ax.plot(r.ts["t"], r.ts[ch].to_numpy() * scale, lw=0.9, color=col[k], label=k)
        if decorate:
            decorate(ax, s, have, col)
        _style(ax, ylabel, title=f"{cname}" if cname else None)
        _legend(ax, len(have))
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title + _title_suffix(results), fontsize=12)
    return _save(fig, out_dir / fname)


# --------------------------------------------------------------------------------------------------- PSD
def welch_psd(x, fs: float, resolution: float = 0.25):
    """One-sided Welch PSD of ``x`` (Hann windows, 50 % overlap) aiming at ``resolution`` Hz, with at least
    a few averages on short records.  Returns (f, Pxx)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    nper = int(min(n, max(64, round(fs / resolution))))
    if n >= 256 and nper > n // 2:  # keep >= 3 averages (50 % overlap)
        nper = n // 2
    return signal.welch(x, fs=fs, window="hann", nperseg=nper, detrend="constant")


def plot_psd_comparison(results, channel: str = "body_acc", out_path=None, axes=None, weighting: str | None = "Wk",
                        fmax: float = 100.0, unit: str = "m/s²"):
    """Overlay Welch PSDs of ``channel`` for several runs (log-log).  With ``weighting`` (an ISO 2631-1
    weighting name) a second panel shows the weighted PSD |W(f)|²·S(f), whose integral is a_w².  Draws on
    ``axes`` (a sequence of one or two Axes) if given, else on a new figure saved to ``out_path`` when set.
    Returns the figure."""
    from .metrics.iso2631 import iso2631_weighting, weighted

    results = _as_dict(results)
    have = {k: r for k, r in results.items() if channel in r.ts and len(r.ts) > 16}
    npan = 2 if weighting else 1
    own = axes is None
    if own:
        fig, axes = _fig(npan, height=3.0)
    else:
        fig = axes[0].figure
    col = _colors(results)
    top = [0.0] * npan
    for k, r in have.items():
        x = r.ts[channel].to_numpy()
        fs = _fs(r.ts)
        f, p = welch_psd(x, fs)
        m = (f > 0) & (f <= min(fmax, fs / 2))
        lab = f"{k} (RMS {np.sqrt(np.mean(x ** 2)):.3g} {unit})"
        axes[0].loglog(f[m], p[m], lw=1.0, color=col[k], label=lab)
        top[0] = max(top[0], float(np.max(p[m], initial=0.0)))
        if weighting:
            aw = weighted(x, fs, weighting)
            wl = f"{k} (a_w {np.sqrt(np.mean(aw ** 2)):.3g} {unit})"
            pw = p[m] * iso2631_weighting(f[m], weighting) ** 2
            axes[1].loglog(f[m], pw, lw=1.0, color=col[k], label=wl)
            top[1] = max(top[1], float(np.max(pw, initial=0.0)))
    for ax, t in zip(axes, top):  # show 8 decades below the peak, not numerical noise floors
        if t > 0:
            ax.set_ylim(t * 1e-8, t * 3)
    _style(axes[0], f"PSD ({unit})²/Hz", title=f"{channel}: Welch PSD")
    _legend(axes[0], len(have))
    if weighting:
        _style(axes[1], f"PSD ({unit})²/Hz", title=f"{weighting}-weighted (ISO 2631-1)")
        _legend(axes[1], len(have))
    axes[-1].set_xlabel("frequency (Hz)")
    if own:
        fig.suptitle(f"Power spectral density of {channel}" + _title_suffix(results), fontsize=12)
    if out_path is not None:
        _save(fig, Path(out_path))
    return fig


# --------------------------------------------------------------------------------------------------- main
def plot_run(results, out_dir) -> list[Path]:
    """Write the standard PNGs for ``results`` (``{label: Result}``, a list of Results, or one Result) into
    ``out_dir``; returns the paths written."""
    results = _as_dict(results)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not results:
        return []
    written: list[Path | None] = []
    # spectra need every sample: a long run's preview keeping every q-th instant (q > 1) would alias, so its
    # PSD and gain plots are left out (its time plots show the preview)
    full_rate = {k: r for k, r in results.items()
                 if ((r.info or {}).get("streamed_log") or {}).get("preview_every", 1) == 1}

    def acc_label(ax, s, have, col):
        for line in ax.get_lines():
            r = results.get(line.get_label())
            aw = (r.metrics or {}).get("body_acc_wk_rms") if r is not None else None
            if aw is not None:
                line.set_label(f"{line.get_label()} (RMS {r.metrics.get('body_acc_rms', np.nan):.3g}, "
                               f"Wk {aw:.3g} m/s²)")

    written.append(_time_series(results, out_dir, "body_acceleration.png", "Body heave acceleration (c.g.)",
                                "body_acc", "acceleration (m/s²)", per_corner=False, decorate=acc_label))
    if any("body_acc" in r.ts for r in full_rate.values()):
        written.append(_save(plot_psd_comparison(full_rate, "body_acc"), out_dir / "body_acc_psd.png"))

    def gaps(ax, s, have, col):
        g = set()
        for _, r in have:
            sides = (r.info.get("stop_gap_sides") or {}).get(s)
            gap = (r.info.get("stop_gap") or {}).get(s)
            if sides is None and gap is not None:
                sides = (gap, gap)
            if sides is not None:
                g.add((-float(sides[0]), float(sides[1])))
        for i, (lo, hi) in enumerate(sorted(g)):
            ax.axhline(1000 * hi, color="k", ls="--", lw=0.7, label="bump stops" if i == 0 else None)
            ax.axhline(1000 * lo, color="k", ls="--", lw=0.7)

    written.append(_time_series(results, out_dir, "suspension_travel.png", "Suspension travel (+ = extension)",
                                "travel", "travel (mm)", scale=1000.0, decorate=gaps))

    def liftoff(ax, s, have, col):
        for k, r in have:
            static = (r.info.get("static_tire_force") or {}).get(s)
            ch = f"tire_force{s}"
            if static and ch in r.ts and r.ts[ch].min() < -0.5 * static:
                ax.axhline(-static, color=col[k], ls="--", lw=0.7, label=f"lift-off ({k}: −static load)")

    written.append(_time_series(results, out_dir, "tire_load.png", "Dynamic tire load (+ = more compression)",
                                "tire_force", "dynamic tire force (N)", decorate=liftoff))
    written.append(_time_series(results, out_dir, "actuator_force.png",
                                "Actuator force (+ = body up, wheel down)", "actuator_force", "force (N)"))
    written.append(_attitude(results, out_dir))
    # runs with actuator states or controller signals (hydraulic actuator, adaptive controllers) also get
    # those and the body/wheel displacements (the quantities of the papers' figures)
    if any(c.startswith(("act.", "ctrl.")) for r in results.values() for c in r.ts.columns):
        written.append(_signals(results, out_dir, ("body_z", "wheel_z"), "displacements.png",
                                "Body and wheel displacement from equilibrium (m)"))
        written.append(_signals(results, out_dir, "act.", "actuator_states.png", "Actuator internal states"))
        written.append(_signals(results, out_dir, "ctrl.", "controller_signals.png", "Controller signals"))
    # random-road runs: gain factors and PSDs against the reference model of adaptive controllers
    from .plots_frequency import plot_frequency

    if full_rate:
        written.extend(plot_frequency(full_rate, out_dir))
    return [p for p in written if p is not None]


def _signals(results: dict, out_dir: Path, select, fname: str, title: str, max_panels: int = 12) -> Path | None:
    """One panel per channel (``select``: a column-name prefix or a tuple of names), runs overlaid: actuator
    states (spool position, load pressure, ...), controller signals (desired force, estimates, errors)."""
    names: list[str] = []
    for r in results.values():
        for c in r.ts.columns:
            ok = c in select if isinstance(select, tuple) else c.startswith(select)
            if ok and c not in names:
                names.append(c)
    names = names[:max_panels]
    if not names:
        return None
    col = _colors(results)
    fig, axes = _fig(len(names), height=2.0)
    for ax, ch in zip(axes, names):
        n = 0
        for k, r in results.items():
            if ch in r.ts:
                ax.plot(r.ts["t"], r.ts[ch].to_numpy(), lw=0.9, color=col[k], label=k)
                n += 1
        _style(ax, ch)
        _legend(ax, n)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title + _title_suffix(results), fontsize=12)
    return _save(fig, out_dir / fname)


def _attitude(results: dict, out_dir: Path) -> Path | None:
    dofs = [d for d in ("pitch", "roll") if any(d in r.ts for r in results.values())]
    if not dofs:
        return None
    col = _colors(results)
    fig, axes = _fig(len(dofs))
    sign = {"pitch": "+ = nose down", "roll": "+ = right side down"}
    for ax, d in zip(axes, dofs):
        n = 0
        for k, r in results.items():
            if d in r.ts:
                ax.plot(r.ts["t"], np.degrees(r.ts[d].to_numpy()), lw=0.9, color=col[k], label=k)
                n += 1
        _style(ax, f"{d} (deg)", title=f"{d} ({sign[d]})")
        _legend(ax, n)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle("Body attitude" + _title_suffix(results), fontsize=12)
    return _save(fig, out_dir / "attitude.png")


__all__: Iterable[str] = ["plot_run", "plot_psd_comparison", "welch_psd"]
