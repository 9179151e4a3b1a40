"""stable-baselines3 on the compiled ensemble: :class:`SB3VecEnv` presents a
:class:`~suspension_sim.rl.env.SuspensionVectorEnv` as an SB3 ``VecEnv`` (``pip install -e ".[rl]"``).

SB3 resets a finished sub-env within the same step (the observation returned is the new episode's first,
the last one is in ``info["terminal_observation"]``); the vector env resets at the next step (NEXT_STEP).
The adapter bridges the two: when the ensemble's episode ends (all cars truncate together at
``sim.duration``) it takes the extra step at once, so the cars start their new episodes in the same call;
a car that terminates early returns its terminal observation also as its "first" observation, and its
in-place restart on the next step is passed on as a transition with reward 0.  ``info["episode"]`` carries
``{"r": return, "l": length}`` at each episode's end (as SB3's Monitor does), for the learning curve.
"""
from __future__ import annotations

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


class SB3VecEnv(VecEnv):
    def __init__(self, venv):
        self.venv = venv
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions = None
        self._ret = np.zeros(self.num_envs)
        self._len = np.zeros(self.num_envs, dtype=int)
        self._seed = None
        # (total env steps at the end, return, length, fresh): fresh = the episode began with the ensemble's
        # (at rest, t = 0), not by an in-place restart after a termination (those are shorter, their returns
        # not comparable)
        self.episodes: list[tuple[int, float, int, bool]] = []
        self._fresh = np.ones(self.num_envs, bool)
        self.total_steps = 0

    def reset(self):
        obs, _ = self.venv.reset(seed=self._seed)
        self._seed = None
        self._ret[:] = 0
        self._len[:] = 0
        self._fresh[:] = True
        return obs

    def step_async(self, actions):
        self._actions = np.asarray(actions, dtype=np.float32).reshape(self.num_envs, -1)

    def step_wait(self):
        obs, rew, term, trunc, _ = self.venv.step(self._actions)
        self.total_steps += self.num_envs
        done = term | trunc
        self._ret += rew
        self._len += 1
        infos = [{} for _ in range(self.num_envs)]
        for i in np.nonzero(done)[0]:
            infos[i]["terminal_observation"] = obs[i].copy()
            infos[i]["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
            infos[i]["episode"] = {"r": float(self._ret[i]), "l": int(self._len[i])}
            self.episodes.append((self.total_steps, float(self._ret[i]), int(self._len[i]), bool(self._fresh[i])))
            self._ret[i] = 0.0
            self._len[i] = 0
            self._fresh[i] = False
        if done.all():  # the ensemble starts over: take the reset step now
            obs, _, _, _, _ = self.venv.step(np.zeros_like(self._actions))
            self._fresh[:] = True
        return obs, rew.astype(np.float32), done, infos

    def close(self):
        self.venv.close()

    def seed(self, seed=None):
        self._seed = seed
        return [seed]

    def get_attr(self, attr_name, indices=None):
        return [getattr(self.venv, attr_name)] * len(self._idx(indices))

    def set_attr(self, attr_name, value, indices=None):
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name, *args, indices=None, **kwargs):
        return [getattr(self.venv, method_name)(*args, **kwargs) for _ in self._idx(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None):
        return [False] * len(self._idx(indices))

    def _idx(self, indices):
        if indices is None:
            return range(self.num_envs)
        return [indices] if isinstance(indices, int) else list(indices)
