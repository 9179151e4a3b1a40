"""Environment steps per second of the Gymnasium envs (suspension_sim/rl) against a plain Python quarter-car
ODE env of the kind RL papers write by hand, for N = 1, 16 and 256 cars.

    python benchmarks/bench_gym.py [--episodes 2]

One env step = one control step of 5 ms (10 physics steps of 0.5 ms) of one car, random actions.  Ours:
``SuspensionEnv`` for N = 1, ``SuspensionVectorEnv`` (one ensemble in the compiled loop) for N > 1.  The
Python env: the same quarter car (290/59 kg, 16812 N/m, 1000 N·s/m, 190 kN/m tire), a pre-generated ISO 8608
class C road (inverse FFT), 10 semi-implicit Euler sub-steps per env step in plain Python floats, no sensor noise or Wk
filter; N > 1 through ``gymnasium.vector.SyncVectorEnv``.  Also printed: the same env integrated by
``solve_ivp`` per step.  The last column is the batch engine's own cost
for the same car-steps (passive controller, fully compiled, metrics-only logging): the floor the vector env
approaches as N grows (its run includes generating the roads and computing the metrics).  Rates are per
second of the process's CPU time, so that other processes on a shared machine do not count.
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
        # ISO 8608 class C (Gd(n0) = 256e-6 m³, waviness 2) by inverse FFT with random phases
        m = self.n_steps * self.sub + 1
        dx = self.speed * self.dt
        n = np.fft.rfftfreq(2 * m, dx)[1:]
        amp = np.sqrt(256e-6 * (n / 0.1) ** -2 * (n[0]) / 2) * 2 * m
        spec = np.concatenate([[0.0], amp * np.exp(1j * self.np_random.uniform(0, 2 * np.pi, n.size))])
        self.road = np.fft.irfft(spec, 2 * m)[:m].tolist()
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


class SolveIvpQuarterCarEnv(PythonQuarterCarEnv):
    """The same env integrated by ``scipy.integrate.solve_ivp`` (RK45) over each control step, road linear
    between samples: the other way such envs are commonly written."""

    def step(self, action):
        from scipy.integrate import solve_ivp

        F = float(np.clip(action[0], -1, 1)) * self.fmax
        ms, mu, ks, cs, kt = self.ms, self.mu, self.ks, self.cs, self.kt
        t0 = self.k * self.sub * self.dt
        road = self.road

        def rhs(t, x):
            zs, vs, zu, vu = x
            j = (t - t0) / self.dt
            i = min(int(j), self.sub - 1)
            zr = road[self.k * self.sub + i] + (j - i) * (road[self.k * self.sub + i + 1] - road[self.k * self.sub + i])
            fs = ks * (zs - zu) + cs * (vs - vu) - F
            return [vs, -fs / ms, vu, (fs - kt * (zu - zr)) / mu]

        sol = solve_ivp(rhs, (t0, t0 + self.sub * self.dt), [self.zs, self.vs, self.zu, self.vu], rtol=1e-6, atol=1e-9)
        self.zs, self.vs, self.zu, self.vu = sol.y[:, -1]
        self.acc = rhs(t0 + self.sub * self.dt, sol.y[:, -1])[1]
        self.k += 1
        return self._obs(), -self.acc ** 2, False, self.k >= self.n_steps, {}


def _rate(step, reset, n_cars, episodes):
    """Car env-steps per second of this process's CPU time over whole episodes (their resets included; the
    machine is shared: wall time would measure the other processes too; nothing here runs threads)."""
    reset()
    t0 = time.process_time()
    n = episodes * EPISODE_STEPS
    for _ in range(n):
        step()
    return n * n_cars / (time.process_time() - t0)


EPISODE_STEPS = 1000  # 5 s at 5 ms


def ours(n, episodes):
    rng = np.random.default_rng(0)
    if n == 1:
        env = SuspensionEnv("quarter_car")
        a = rng.uniform(-1, 1, (1,)).astype(np.float32)

        def step():
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        return _rate(step, lambda: env.reset(seed=0), 1, episodes)
    venv = SuspensionVectorEnv(n, "quarter_car")
    a = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
    return _rate(lambda: venv.step(a), lambda: venv.reset(seed=0), n, episodes)


def python_env(n, episodes):
    rng = np.random.default_rng(0)
    if n == 1:
        env = PythonQuarterCarEnv()
        a = rng.uniform(-1, 1, (1,)).astype(np.float32)

        def step():
            _, _, te, tr, _ = env.step(a)
            if te or tr:
                env.reset()
        return _rate(step, lambda: env.reset(seed=0), 1, episodes)
    venv = gym.vector.SyncVectorEnv([PythonQuarterCarEnv for _ in range(n)])
    a = rng.uniform(-1, 1, (n, 1)).astype(np.float32)
    return _rate(lambda: venv.step(a), lambda: venv.reset(seed=0), n, episodes)


def batch_engine(n):
    """Car env-steps per second of the batch engine itself (same scenario, passive, fully compiled)."""
    from suspension_sim.config import parse_scenario
    from suspension_sim.rl.presets import preset
    from suspension_sim.simulation import Simulation

    sc = parse_scenario(preset("quarter_car"))
    sim = Simulation([sc] * n, log_channels="metrics")
    sim.run()  # compile / load the kernel
    t0 = time.process_time()
    sim.run()
    cpu = time.process_time() - t0
    return n * sim.n_steps / sim.sub / cpu, sim.loop


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=2, help="whole 5 s episodes per measurement")
    ap.add_argument("--sizes", default="1,16,256")
    args = ap.parse_args()
    print("car env-steps per CPU second (one env step = 5 ms of one car)")
    print(f"{'N':>5} {'ours':>18} {'python ODE env':>16} {'ratio':>7} {'batch engine':>14}")
    for n in (int(s) for s in args.sizes.split(",")):
        o = ours(n, args.episodes)
        p = python_env(n, args.episodes)
        b, loop = batch_engine(n)
        print(f"{n:>5} {o:>18,.0f} {p:>16,.0f} {o / p:>6.1f}x {b:>14,.0f}  ({loop} loop)")
    env = SolveIvpQuarterCarEnv()
    a = np.zeros(1, np.float32)
    env.reset(seed=0)
    t0 = time.process_time()
    for _ in range(EPISODE_STEPS):
        env.step(a)
    print(f"python solve_ivp env: {EPISODE_STEPS / (time.process_time() - t0):,.0f} car env-steps per CPU second "
          "(any N: SyncVectorEnv steps the envs one after the other)")


if __name__ == "__main__":
    main()
