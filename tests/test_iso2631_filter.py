"""The ISO 2631 weighting filter runs scipy's ``sosfilt`` recursion over blocks of cars side by side
(:func:`~suspension_sim.metrics.iso2631.sosfilt_rows`); it must give scipy's numbers bit for bit, for any number of
cars (blocks of 16 and a remainder), with the state carried across chunks and only every ``step``-th output kept."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from suspension_sim.metrics.iso2631 import sosfilt_rows, weighting_sos


@pytest.mark.parametrize("n_cars", [1, 7, 16, 37])
@pytest.mark.parametrize("step", [1, 2, 3])
def test_sosfilt_rows_is_scipys_sosfilt(n_cars, step):
    sos = weighting_sos(2000.0, "Wk")
    rng = np.random.default_rng(n_cars * 10 + step)
    x = rng.standard_normal((n_cars, 3001)) * np.logspace(-3, 2, n_cars)[:, None]
    x[0, 100] = np.nan if n_cars > 1 else x[0, 100]  # a NaN stays in its own car
    zi = np.zeros((sos.shape[0], n_cars, 2))
    z_ref = zi.copy()
    for a, b in [(0, 1), (1, 1200), (1200, 3001)]:  # chunks, the state carried over
        y_ref, z_ref = signal.sosfilt(sos, x[:, a:b], axis=-1, zi=z_ref)
        y = sosfilt_rows(sos, x[:, a:b], zi, step)
        np.testing.assert_array_equal(y, y_ref[:, ::step])  # bit for bit (NaN in the same places)
        np.testing.assert_array_equal(zi, z_ref)
    assert np.isfinite(y[-1]).all() and np.any(y[-1] != 0)


class _ScipyStream:
    """The weighting stream as written with scipy alone (resample_poly, then sosfilt, then every up-th sample):
    the reference the one-pass kernel must equal bit for bit."""

    def __init__(self, n_cars, fs):
        from suspension_sim.metrics.iso2631 import MIN_FILTER_RATE, _upsampling_window

        self.window = _upsampling_window
        self.up = max(1, int(np.ceil(MIN_FILTER_RATE / fs - 1e-9)))
        self.sos = weighting_sos(fs * self.up)
        self.zi = np.zeros((self.sos.shape[0], n_cars, 2))
        self.margin, self.buf, self.buf0, self.done = 12, np.zeros((n_cars, 0)), 0, 0

    def push(self, x, final=False):
        if x is not None and x.shape[1]:
            self.buf = x if self.buf.shape[1] == 0 else np.concatenate([self.buf, x], axis=1)
        total = self.buf0 + self.buf.shape[1]
        if self.up == 1:
            xu, self.buf, self.buf0 = self.buf, self.buf[:, :0], total
            if xu.shape[1] == 0:
                return xu
            y, self.zi = signal.sosfilt(self.sos, xu, axis=-1, zi=self.zi)
            return y
        end = total if final else total - self.margin
        if end <= self.done:
            return self.buf[:, :0]
        seg0 = max(self.buf0, self.done - self.margin)
        seg1 = total if final else min(total, end + self.margin)
        seg = self.buf[:, seg0 - self.buf0:seg1 - self.buf0]
        xu = signal.resample_poly(seg, self.up, 1, axis=-1, padtype="edge", window=self.window(self.up))
        xu = xu[:, (self.done - seg0) * self.up:(end - seg0) * self.up]
        y, self.zi = signal.sosfilt(self.sos, xu, axis=-1, zi=self.zi)
        self.done = end
        keep = max(self.buf0, end - self.margin)
        self.buf, self.buf0 = np.array(self.buf[:, keep - self.buf0:]), keep
        return y[:, ::self.up]


@pytest.mark.parametrize("fs", [1000.0, 700.0, 2000.0])  # upsampled by 2, by 3, not upsampled
@pytest.mark.parametrize("chunks", [[1500], [5, 400, 1, 700, 394], [30] * 50])
def test_weighted_stream_is_resample_poly_then_sosfilt(fs, chunks):
    from suspension_sim.metrics.iso2631 import WeightedStream

    rng = np.random.default_rng(len(chunks))
    n_cars = 19
    x = np.cumsum(rng.standard_normal((n_cars, sum(chunks))), axis=1) * 0.1 + 3.0  # edges far from 0
    new, ref = WeightedStream(n_cars, fs), _ScipyStream(n_cars, fs)
    got, want = [], []
    a = 0
    for c in chunks:
        got.append(new.push(x[:, a:a + c]))
        want.append(ref.push(x[:, a:a + c]))
        a += c
    got.append(new.push(None, final=True))
    want.append(ref.push(None, final=True))
    g, w = np.concatenate(got, axis=1), np.concatenate(want, axis=1)
    assert g.shape == (n_cars, sum(chunks)) and np.any(g != 0)
    np.testing.assert_array_equal(g, w)
