"""The standard plots are written, are real PNGs and show what they claim."""
import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread

import suspension_sim as ss
from suspension_sim.config import parse_scenario
from suspension_sim.plots import plot_psd_comparison, plot_run, welch_psd
from suspension_sim.outputs import write_result
from suspension_sim.results import Result, compute_metrics

STANDARD = {"body_acceleration.png", "body_acc_psd.png", "suspension_travel.png", "tire_load.png",
            "actuator_force.png"}


def _pair(model: str, duration: float = 1.0) -> dict:
    """Passive and skyhook runs to plot, in the Python loop: the plots do not depend on the loop (the results
    are the same), and the compiled loop would compile three loops no other test uses for 1 s of
    simulation each (10-15 CPU-s apiece on a cold compile cache)."""
    base = {"name": f"{model}_plot", "vehicle": {"model": model},
            "road": {"type": "sine", "params": {"frequency": 2.0, "amplitude": 0.01}},
            "sensors": [{"type": "corner_body_vel"}], "sim": {"duration": duration}}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SUSPENSION_SIM_COMPILED", "0")
        return {"passive": ss.simulate(parse_scenario({**base, "name": f"{model}_plot/passive"})),
                "skyhook": ss.simulate(parse_scenario({**base, "name": f"{model}_plot/skyhook",
                                                       "controller": {"type": "skyhook"}}))}


def _check_png(p):
    assert p.exists() and p.stat().st_size > 5000
    assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(p)
    assert img.shape[0] > 200 and img.shape[1] > 500
    assert img[..., :3].std() > 0.01  # not a blank canvas


@pytest.fixture(scope="module")
def quarter_pair():
    return _pair("quarter_car")


def test_quarter_car_passive_vs_skyhook(tmp_path, quarter_pair):
    res = quarter_pair
    written = plot_run(res, tmp_path / "plots")
    names = {p.name for p in written}
    assert names == STANDARD  # no pitch/roll in a quarter car
    for p in written:
        _check_png(p)


def test_half_car_has_corner_subplots_and_attitude(tmp_path):
    res = _pair("half_car")
    written = plot_run(res, tmp_path)
    assert {p.name for p in written} == STANDARD | {"attitude.png"}
    for p in written:
        _check_png(p)
    # a per-corner figure is taller than the single-panel body acceleration figure
    h = {p.name: imread(p).shape[0] for p in written}
    assert h["suspension_travel.png"] > 1.5 * h["body_acceleration.png"]


def test_write_result_writes_plots(tmp_path, quarter_pair):
    r = quarter_pair["skyhook"]
    write_result(r, tmp_path / "run")
    assert {p.name for p in (tmp_path / "run" / "plots").glob("*.png")} == STANDARD


def test_decorations_and_missing_channels(tmp_path):
    # synthetic one-corner log with a bump-stop gap and tire lift-off, and no actuator/tire channels in
    # the second run: figures still come out, lines only for runs that have the channel
    t = np.arange(3000) / 1000.0
    df = pd.DataFrame({"t": t, "body_acc": np.sin(2 * np.pi * 4 * t), "travel": 0.04 * np.sin(2 * np.pi * t),
                       "travel_rate": 0.08 * np.pi * np.cos(2 * np.pi * t),
                       "tire_force": 4000 * np.sin(2 * np.pi * 3 * t), "actuator_force": 0 * t})
    info = {"suffixes": [""], "corners": ["single"], "static_tire_force": {"": 3000.0}, "stop_gap": {"": 0.03}}
    a = Result(scenario=None, timeseries=df, info=info)
    a.metrics = compute_metrics(a)
    b = Result(scenario=None, timeseries=df[["t", "body_acc", "travel"]], info=info)
    written = plot_run({"a": a, "b": b}, tmp_path)
    assert {p.name for p in written} == STANDARD
    for p in written:
        _check_png(p)


def test_psd_comparison_peaks_at_the_sine_frequency():
    fs, f0 = 1000.0, 6.0
    t = np.arange(int(8 * fs)) / fs
    df = pd.DataFrame({"t": t, "body_acc": np.sin(2 * np.pi * f0 * t)})
    r = Result(scenario=None, timeseries=df, info={"suffixes": [""]})
    fig = plot_psd_comparison({"sine": r})
    ax0, ax1 = fig.axes[:2]
    x, y = ax0.get_lines()[0].get_data()
    assert x[np.argmax(y)] == pytest.approx(f0, abs=0.3)
    # the Welch PSD integrates to the mean square (0.5 for a unit sine)
    f, p = welch_psd(df["body_acc"].to_numpy(), fs)
    assert np.trapezoid(p, f) == pytest.approx(0.5, rel=0.02)
    # weighted panel = |Wk|² times the unweighted one
    from suspension_sim.metrics.iso2631 import iso2631_weighting

    xw, yw = ax1.get_lines()[0].get_data()
    np.testing.assert_allclose(yw, y * iso2631_weighting(x) ** 2, rtol=1e-12)


def test_runs_with_controller_and_actuator_signals_get_their_figures(tmp_path):
    """Runs logging actuator states (act.*) or controller signals (ctrl.*) also get the displacements, the
    actuator states and the controller signals, a panel per channel, runs overlaid; a run without them does not."""
    t = np.arange(2000) / 1000.0
    df = pd.DataFrame({"t": t, "body_z": 0.01 * np.sin(2 * np.pi * t), "wheel_z": 0.002 * np.sin(9 * t),
                       "body_acc": np.sin(7 * t), "act.spool": np.cos(3 * t), "ctrl.err": 0.1 * t,
                       "ctrl.theta.0": np.tanh(t)})
    info = {"suffixes": [""], "corners": ["single"]}
    a = Result(scenario=None, timeseries=df, info=info)
    b = Result(scenario=None, timeseries=df[["t", "body_z", "body_acc", "ctrl.err"]], info=info)
    written = {p.name: p for p in plot_run({"a": a, "b": b}, tmp_path)}
    signals = {"displacements.png", "actuator_states.png", "controller_signals.png"}
    assert signals <= set(written)
    for k in signals:
        _check_png(written[k])
    h = {k: imread(written[k]).shape[0] for k in signals}
    assert h["controller_signals.png"] > 1.5 * h["actuator_states.png"]  # two panels against one
    plain = {p.name for p in plot_run({"b": Result(scenario=None, timeseries=df[["t", "body_z", "body_acc"]],
                                                   info=info)}, tmp_path / "plain")}
    assert not plain & signals
