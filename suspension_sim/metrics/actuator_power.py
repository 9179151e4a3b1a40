"""Actuator mechanical power and energy per corner (and summed over corners)."""
import numba
import numpy as np

from ..compiled.numpy_order import leaf_sums, pairwise_plan, pairwise_sum, push_leaf
from ..registry import METRICS
from .base import Accumulator, is_steps, max_nonneg, metric, rows_of, trapezoid_terms

_SUMMED = ("actuator_power_mean_abs", "actuator_power_mean_pos", "actuator_energy")


@METRICS.register("actuator_power")
@metric
class ActuatorPower(Accumulator):
    """Actuator mechanical power P = F·(travel rate): mean |P|, mean positive P (W) and energy ∫|P|dt (J).

    With the sign conventions (F > 0 pushes the body up and the wheel down, travel > 0 = extension),
    P = F·(ż_body − ż_wheel) is the power the actuator puts into the suspension: P > 0 it drives the motion,
    P < 0 it absorbs energy (acts as a damper).  Keys per corner:

    - ``actuator_power_mean_abs{s}`` = mean |P|, the average power flow through the actuator;
    - ``actuator_power_mean_pos{s}`` = mean max(P, 0), what an actuator that cannot regenerate must supply;
    - ``actuator_power_peak{s}`` = max |P|;
    - ``actuator_energy{s}`` = ∫|P| dt (trapezoid rule over the log), J.

    These are mechanical quantities at the actuator, not electrical or hydraulic input power (losses are the
    actuator model's business).  Multi-corner models also get ``..._total`` sums over corners.
    """

    channels = ("actuator_force{s}", "travel_rate{s}")

    def update(self, chunk) -> None:
        self.r.start(chunk)
        t = np.ascontiguousarray(chunk.t, dtype=np.float64)
        for s in chunk.suffixes:
            F, v = chunk.held(f"actuator_force{s}"), chunk.held(f"travel_rate{s}")
            steps = is_steps(F) and is_steps(v)  # step-major: the cars side by side, the same numbers
            if not steps:
                F, v = rows_of(F), rows_of(v)
            # p = F·v, a = |p|: sums of a and of max(p, 0), ∫ a dt (trapezoid, the last chunk's sample joined on)
            # and max a, in one compiled pass: np.sum, np.clip, scipy's trapezoid and np.max's numbers
            prev = self.r.last.get(f"e{s}")
            n_cars, n = F.shape
            py = prev[0][:, 0] if prev is not None else np.zeros(n_cars)
            pt = float(prev[1][0]) if prev is not None else 0.0
            out = np.empty((5, n_cars))
            (_power_steps(F.T, v.T, t, py, pt, prev is not None, out) if steps else
             _power(F, v, t, py, pt, prev is not None, out))
            if n:
                self.r.sum_value(f"abs{s}", out[0])
                self.r.sum_value(f"pos{s}", out[1])
                self.r.max_value(f"pk{s}", out[3])
            else:
                self.r.sum_value(f"abs{s}", np.zeros(n_cars))
                self.r.sum_value(f"pos{s}", np.zeros(n_cars))
            joined = n + (prev is not None)
            if joined:
                self.r.trapezoid_value(f"e{s}", out[2] if joined > 1 else None, out[4][:, None] if n else prev[0],
                                       t[-1:] if n else prev[1])

    def result(self) -> dict:
        out, tot = {}, dict.fromkeys(_SUMMED, 0.0)
        for s in self.meta.suffixes:
            vals = dict(zip(_SUMMED, (self.r.mean(f"abs{s}"), self.r.mean(f"pos{s}"), self.r.get(f"e{s}", 0.0))))
            for k, v in vals.items():
                out[f"{k}{s}"] = v
                tot[k] = tot[k] + v
            out[f"actuator_power_peak{s}"] = self.r.get(f"pk{s}")
        if len(self.meta.suffixes) > 1:
            out.update({f"{k}_total": v for k, v in tot.items()})
        return out


@numba.njit(cache=True, nogil=True)
def _power(F, v, t, prev_y, prev_t, has_prev, out):  # pragma: no cover - compiled
    """Per car r, a = |F·v|: out[0] = Σ a, out[1] = Σ max(F·v, 0), out[2] = trapezoid ∫ a dt over the chunk
    with the previous chunk's last sample (prev_y[r] at prev_t) joined on, out[3] = max a (NaN if any),
    out[4] = the last a; the numbers of np.sum, np.clip, scipy.integrate.trapezoid and np.max."""
    n = F.shape[1]
    a = np.empty(n)
    pos = np.empty(n)
    tmp = np.empty(n + 1)
    for r in range(F.shape[0]):
        for j in range(n):
            p = F[r, j] * v[r, j]
            a[j] = abs(p)
            pos[j] = p if p > 0.0 or p != p else 0.0
        out[0, r] = pairwise_sum(a, 0, n)
        m = (max_nonneg(a, n) if out[0, r] == out[0, r] else np.nan) if n else 0.0  # Σ a is NaN iff an a is
        out[1, r] = pairwise_sum(pos, 0, n)
        q = trapezoid_terms(a, t, prev_y[r], prev_t, has_prev, tmp)
        out[2, r] = pairwise_sum(tmp, 0, q)
        out[3, r] = m
        out[4, r] = a[n - 1] if n else 0.0


@numba.njit(cache=True, nogil=True)
def _power_steps(F, v, t, prev_y, prev_t, has_prev, out):  # pragma: no cover - compiled
    """:func:`_power` of step-major ``F``, ``v`` (rows, cars): the same terms and, per car, the same trees of
    additions (numpy's pairwise order, :func:`~suspension_sim.compiled.numpy_order.pairwise_plan`) with the
    cars side by side, so the same numbers."""
    n, m = F.shape
    T = np.empty((128, m))
    T2 = np.empty((128, m))
    acc = np.empty((8, m))
    res = np.empty(m)
    stack = np.empty((64, m))
    stack2 = np.empty((64, m))
    for c in range(m):
        out[3, c] = 0.0
    # Σ a and Σ max(p, 0) over the n samples, max a
    lo, ln, merges = pairwise_plan(n)
    top = top2 = 0
    for li in range(lo.shape[0]):
        r0 = lo[li]
        for i in range(ln[li]):
            for c in range(m):
                p = F[r0 + i, c] * v[r0 + i, c]
                a = abs(p)
                T[i, c] = a
                T2[i, c] = p if p > 0.0 or p != p else 0.0
                out[3, c] = a if a > out[3, c] else out[3, c]
        leaf_sums(T, ln[li], acc, res)
        top = push_leaf(stack, top, res, merges[li])
        leaf_sums(T2, ln[li], acc, res)
        top2 = push_leaf(stack2, top2, res, merges[li])
    for c in range(m):
        out[0, c] = stack[0, c]
        out[1, c] = stack2[0, c]
        if n == 0:
            out[3, c] = 0.0
        elif out[0, c] != out[0, c]:
            out[3, c] = np.nan
        out[4, c] = abs(F[n - 1, c] * v[n - 1, c]) if n else 0.0
    # the trapezoid terms ((t[j+1] − t[j])·(a[j+1] + a[j])) / 2.0, the previous chunk's last sample joined on
    h = 1 if has_prev and n > 0 else 0
    q = n - 1 + h if n > 0 else 0
    lo, ln, merges = pairwise_plan(q)
    top = 0
    for li in range(lo.shape[0]):
        for i in range(ln[li]):
            g = lo[li] + i
            if h == 1 and g == 0:
                for c in range(m):
                    T[i, c] = ((t[0] - prev_t) * (abs(F[0, c] * v[0, c]) + prev_y[c])) / 2.0
            else:
                j = g - h
                for c in range(m):
                    T[i, c] = ((t[j + 1] - t[j]) * (abs(F[j + 1, c] * v[j + 1, c]) + abs(F[j, c] * v[j, c]))) / 2.0
        leaf_sums(T, ln[li], acc, res)
        top = push_leaf(stack, top, res, merges[li])
    for c in range(m):
        out[2, c] = stack[0, c]
