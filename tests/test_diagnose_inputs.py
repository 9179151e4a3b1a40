"""What a measured input did between its samples (``--input-hold``, :func:`suspension_sim.diagnose.datafile.reconstruct`).
The physics step is finer than the record's sample interval, so the simulator needs the inputs between the
samples.  A signal that was low-pass filtered before sampling (or made by a generator with a reconstruction
filter, as the Silverbox input) is band-limited: straight lines between its samples lose a third of its
amplitude at 0.35·fs, the band-limited reconstruction does not."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from suspension_sim.diagnose.calibrate import Problem
from suspension_sim.diagnose.datafile import reconstruct
from suspension_sim.diagnose.io import load_record, record_from_arrays
from suspension_sim.diagnose.model import load_model
from suspension_sim.errors import ScenarioError

warnings.filterwarnings("ignore", category=RuntimeWarning)


def test_reconstruct_between_samples():
    fs, f = 100.0, 35.0
    k = np.arange(400)
    u = np.sin(2 * np.pi * f * k / fs + 0.3)
    t = (np.arange(100, 300) + 0.5) / fs  # half-way between samples, away from the record's ends
    exact = np.sin(2 * np.pi * f * t + 0.3)
    err = {h: np.max(np.abs(reconstruct(u, 1 / fs, t, h) - exact)) for h in ("linear", "bandlimited", "zoh")}
    assert err["bandlimited"] < 1e-4  # the window's truncation error (±32 samples, Blackman): ~1e-5
    assert err["linear"] > 0.3  # a line between samples of a 0.35·fs sine misses most of the swing between them
    assert np.array_equal(reconstruct(u, 1 / fs, k / fs + 0.4 / fs, "zoh"), u)  # held until the next sample
    for h in ("linear", "bandlimited", "zoh"):  # on the samples every hold gives the samples; a constant stays one
        assert np.allclose(reconstruct(u, 1 / fs, k / fs, h), u, atol=1e-12)
        assert np.allclose(reconstruct(np.full(50, 2.5), 1 / fs, np.linspace(-0.1, 0.6, 77), h), 2.5, atol=1e-12)
    # a time a rounding error before a sample (x − floor(x) rounds to 1.0; a fitted delay makes such times) is
    # that sample, not a division by zero
    near = np.array([-1e-17, 5 - 1e-16, np.nextafter(7.0, 0.0)]) / fs
    assert np.allclose(reconstruct(u, 1 / fs, near, "bandlimited"), u[[0, 5, 7]], atol=1e-12)


def test_bad_input_hold_is_a_one_line_error(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("time,force,pos\n" + "".join(f"{i * 0.01},{np.sin(i)},{0.0}\n" for i in range(20)))
    rec = load_record(str(p), "sdof", hold="bandlimited")
    assert rec.hold == "bandlimited" and rec.slice(2, 12).hold == "bandlimited"
    with pytest.raises(ScenarioError, match="unknown input hold 'cubic'"):
        load_record(str(p), "sdof", hold="cubic")


def test_simulated_response_to_a_band_limited_force():
    """A 5 Hz SDOF oscillator forced at 35 Hz, the force sampled at 100 Hz: the simulated steady state against
    the analytic one (amplitude and phase in one number)."""
    fs, f, m, f0, zeta = 100.0, 35.0, 1.0, 5.0, 0.2
    k = m * (2 * np.pi * f0) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    t = np.arange(int(12 * fs)) / fs
    w = 2 * np.pi * f
    u = 100.0 * np.sin(w * t)
    H = 1.0 / (k - m * w ** 2 + 1j * c * w)
    exact = np.imag(100.0 * H * np.exp(1j * w * t))
    spec = load_model({"model": "sdof", "params": {"sprung_mass": m, "spring_stiffness": k, "damping": c},
                       "inputs": {"force_offset": 0.0}})
    err = {}
    for hold in ("linear", "bandlimited"):
        rec = record_from_arrays("sdof", t, {"force": u}, {"pos": exact})
        rec.hold = hold
        sim = Problem(rec, spec, max_dt=1e-3).simulate(spec, spec.P)[:, 0]
        tail = t > 8.0  # the start transient (from rest) has decayed
        err[hold] = np.sqrt(np.mean((sim[tail] - exact[tail]) ** 2)) / np.std(exact[tail])
    # the linear hold's error is its amplitude response at 0.35·fs (sinc²(0.35) = 0.66), with the step's own
    # error on top; the band-limited one leaves the step's error (measured 0.2 %)
    assert err["bandlimited"] < 0.02
    assert err["linear"] > 0.2


def test_held_out_sdof_record_starts_at_its_estimated_state():
    """A held-out record need not start at rest: its state comes from the first, unscored samples (the
    benchmark protocols' "the first 50 samples may initialise the state").  Free decay of a linear SDOF
    oscillator (1.5 Hz, ζ = 0.05) from x0 = 2 cm, v0 = −5 cm/s, against the analytic response."""
    fs, m, f0, zeta, x0, v0 = 200.0, 1.0, 1.5, 0.05, 0.02, -0.05
    w0 = 2 * np.pi * f0
    k, c = m * w0 ** 2, 2 * zeta * m * w0
    wd = w0 * np.sqrt(1 - zeta ** 2)
    t = np.arange(int(4 * fs)) / fs
    x = np.exp(-zeta * w0 * t) * (x0 * np.cos(wd * t) + (v0 + zeta * w0 * x0) / wd * np.sin(wd * t))
    rec = record_from_arrays("sdof", t, {"force": np.zeros_like(t)}, {"pos": x})
    spec = load_model({"model": "sdof", "params": {"sprung_mass": m, "spring_stiffness": k, "damping": c},
                       "inputs": {"force_offset": 0.0}})
    err = {}
    for skip in (0, 50):
        prob = Problem(rec, spec, skip=skip)
        sim = prob.simulate(spec, spec.P)[:, 0]
        err[skip] = np.sqrt(np.mean((sim[50:] - x[50:]) ** 2)) / np.std(x[50:])
    assert prob.init_state and not Problem(rec, spec).init_state
    assert err[0] > 0.9  # from rest: the whole decay is missed
    assert err[50] < 0.02  # the step's own error (first order at 0.5 ms) over a few periods
