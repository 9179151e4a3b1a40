"""Environment steps per second of the Gymnasium envs (suspension_sim/rl) against a plain Python quarter-car
ODE env of the kind RL papers write by hand, for N = 1, 16 and 256 cars.

    python benchmarks/bench_gym.py [--seconds 3]

One env step = one control step of 5 ms (10 physics steps of 0.5 ms) of one car, random actions.  Ours:
``SuspensionEnv`` for N = 1, ``SuspensionVectorEnv`` (one ensemble in the compiled loop) for N > 1.  The
Python env: the same quarter car (290/59 kg, 16812 N/m, 1000 N·s/m, 190 kN/m tire), a pre-generated ISO 8608
class C road, 10 semi-implicit Euler sub-steps per env step in plain Python floats, no sensor noise or Wk
filter; N > 1 through ``gymnasium.vector.SyncVectorEnv``.  The last column is the batch engine's own cost
for the same car-steps (passive controller, fully compiled, metrics-only logging): the floor the vector env
approaches as N grows.  Numbers depend on the machine's load (2 shared cores here).
"""
from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import suspension_sim  # noqa: F401
from suspension_sim.rl.env import SuspensionEnv, SuspensionVectorEnv


class PythonQuarterCarEnv(gym.Env):
    """A hand-written quarter-car env: 2-DOF ODE, Euler sub-steps in Python, ISO 8608 road by sum of sines."""

    def __init__(self, control_dt=0.005, dt=0.0005, duration=5.0, speed=20.0):
        self.ms, self.mu, self.ks, self.cs, self.kt = 290.0, 59.0, 16812.0, 1000.0, 190000.0
        self.dt, self.sub, self.n_steps = dt, int(round(control_dt / dt)), int(round(duration / control_dt))
        self.speed, self.fmax = speed, 3000.0
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        n = np.arange(0.011, 2.83, 0.011)  # spatial frequencies (cycles/m), class C: Gd(n0) = 256e-6 m³
        amp = np.sqrt(2 * 256e-6 * (n / 0.1) ** -2 * 0.011)
        ph = self.np_random.uniform(0, 2 * np.pi, n.size)
        t = np.arange(self.n_steps * self.sub + 1) * self.dt
        x = self.speed * t
        self.road = (amp[None, :] * np.sin(2 * np.pi * n[None, :] * x[:, None] + ph[None, :])).sum(axis=1).tolist()
        self.zs = self.vs = self.zu = self.vu = 0.0
        self.acc = 0.0
        self.k = 0
        return self._obs(), {}

    def _obs(self):
        return np.array([self.acc, self.vs, self.zs - self.zu, self.vs - self.vu], np.float32)

    def step(self, action):
        F = float(np.clip(action[0], -1, 1)) * self.fmax
        ms, mu, ks, cs, kt, dt = self.ms, self.mu, self.ks, self.cs, self.kt, self.dt
        zs, vs, zu, vu = self.zs, self.vs, self.zu, self.vu
        j = self.k * self.sub
        for i in range(self.sub):
            fs = ks * (zs - zu) + cs * (vs - vu) - F
            a_s = -fs / ms
            a_u = (fs - kt * (zu - self.road[j + i])) / mu
            vs += a_s * dt
            vu += a_u * dt
            zs += vs * dt
            zu += vu * dt
        self.zs, self.vs, self.zu, self.vu, self.acc = zs, vs, zu, vu, a_s
        self.k += 1
        reward = -(a_s * a_s + 1e-4 * abs(F * (vs - vu)))
        return self._obs(), reward, False, self.k >= self.n_steps, {}


def _rate(step, reset, n_cars, seconds):
    reset()
    t0 = time.perf_counter()
    steps = 0
    while time.perf_counter() - t0 < seconds:
        for _ in range(50):
            step()
        steps += 50
    return steps * n_cars / (time.perf_counter() - t0)


def ours(n, seconds):
    rng = np.random.default_rng(0)
    if n == 1:
        env = SuspensionEnv("quarter_car")
        a = rng.uniform(-1, 1, (1,)).astype(np.float32)

        def step():
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        return _rate(step, lambda: env.reset(seed=0), 1, seconds)
    venv = SuspensionVectorEnv(n, "quarter_car")
    a = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
    return _rate(lambda: venv.step(a), lambda: venv.reset(seed=0), n, seconds)


def python_env(n, seconds):
    rng = np.random.default_rng(0)
    if n == 1:
        env = PythonQuarterCarEnv()
        a = rng.uniform(-1, 1, (1,)).astype(np.float32)

        def step():
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        return _rate(step, lambda: env.reset(seed=0), 1, seconds)
    venv = gym.vector.SyncVectorEnv([PythonQuarterCarEnv for _ in range(n)])
    a = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
    return _rate(lambda: venv.step(a), lambda: venv.reset(seed=0), n, seconds)


def batch_engine(n):
    """Car env-steps per second of the batch engine itself (same scenario, passive, fully compiled)."""
    from suspension_sim.config import parse_scenario
    from suspension_sim.rl.presets import preset
    from suspension_sim.simulation import Simulation

    sc = parse_scenario(preset("quarter_car"))
    sim = Simulation([sc] * n, log_channels="metrics")
    sim.run()  # compile / load the kernel
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    return n * sim.n_steps / sim.sub / wall, sim.loop


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=3.0, help="wall time per measurement")
    ap.add_argument("--sizes", default="1,16,256")
    args = ap.parse_args()
    print(f"{'N':>5} {'ours env-steps/s':>18} {'python ODE env':>16} {'ratio':>7} {'batch engine':>14}")
    for n in (int(s) for s in args.sizes.split(",")):
        o = ours(n, args.seconds)
        p = python_env(n, args.seconds)
        b, loop = batch_engine(n)
        print(f"{n:>5} {o:>18,.0f} {p:>16,.0f} {o / p:>6.1f}x {b:>14,.0f}  ({loop} loop)")


if __name__ == "__main__":
    main()
