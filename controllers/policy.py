"""A trained policy (reinforcement learning) as a controller, on the CPU, in any scenario.

``controller: {type: policy, params: {path: runs/ppo/policy.npz}}``

The policy sees what the Gymnasium env of :mod:`suspension_sim.rl` gives an agent: the scenario's declared
sensors concatenated in declared order (with ``full_state``, then the ``state.*`` quantities), times
``obs_scale``; its action ``a`` per corner becomes the command ``clip(a, -1, 1) · action_scale``
(``action_scale`` defaults to the actuator's limit, as in the env).  So a policy trained on an env runs on
the same scenario unchanged, and in ``run``, ``batch`` and ``compare`` beside skyhook or the adaptive laws.

Formats (by the file's suffix):

- ``.npz``: a plain multilayer perceptron, no extra package: arrays ``w0, b0, w1, b1, ...`` (``w_k`` of shape
  (inputs, outputs)), optional ``activation`` (``tanh`` default, or ``relu``) between layers, ``output``
  (``clip`` default, or ``tanh`` for a squashed SAC actor), ``obs_mean``/``obs_std`` (normalisation applied
  before the first layer, e.g. from VecNormalize).  :func:`save_npz` writes one; :func:`export_sb3` converts
  a stable-baselines3 PPO/A2C/SAC/TD3 MLP policy.
- ``.zip``: a stable-baselines3 model (``pip install -e ".[rl]"``), its deterministic action.
- ``.onnx``: an ONNX model run by onnxruntime if installed (input: observations (batch, D) float32; first
  output: actions (batch, n_corners)).

Every car of an ensemble may have its own ``path``; cars with the same file are evaluated in one batch.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Union

import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.errors import ScenarioError
from suspension_sim.registry import CONTROLLERS

from .base import Controller


class PolicyParams(Params):
    path: str = Field(..., description="trained policy file: .npz (plain MLP), .zip (stable-baselines3) or .onnx")
    obs_scale: Optional[Union[float, list[float]]] = Field(
        None, description="factor(s) on the observation vector (one, or one per entry), as the env's obs_scale")
    action_scale: Optional[float] = Field(
        None, gt=0, description="command of action +1 (default: the actuator's max_force or spool_limit)")


def command_limit(actuator_params):
    """The actuator's command limit (stacked, (n_cars, 1) or (n_cars, n_corners)): ``max_force`` (ideal),
    ``spool_limit`` (hydraulic); None when it has none (the electromagnetic pair: give the scale)."""
    for name in ("max_force", "spool_limit"):
        v = getattr(actuator_params, name, None) if actuator_params is not None else None
        if v is not None:
            return np.asarray(v, dtype=float)
    return None


def save_npz(path, layers, activation: str = "tanh", output: str = "clip", obs_mean=None, obs_std=None):
    """Write an MLP policy: ``layers`` = [(W (in, out), b (out,)), ...]."""
    arrays = {}
    for k, (w, b) in enumerate(layers):
        arrays[f"w{k}"] = np.asarray(w, dtype=np.float64)
        arrays[f"b{k}"] = np.asarray(b, dtype=np.float64).reshape(-1)
    arrays["activation"] = np.array(activation)
    arrays["output"] = np.array(output)
    if obs_mean is not None:
        arrays["obs_mean"] = np.asarray(obs_mean, dtype=np.float64)
        arrays["obs_std"] = np.asarray(obs_std, dtype=np.float64)
    np.savez(path, **arrays)


def export_sb3(model, path, obs_mean=None, obs_std=None) -> None:
    """Write a stable-baselines3 MLP policy (PPO/A2C: policy_net + action_net; SAC: latent_pi + mu, tanh;
    TD3: actor.mu) as a ``.npz`` that the ``policy`` controller runs without torch."""
    import torch

    pol = model.policy
    lin = []
    if hasattr(pol, "action_net"):  # on-policy actor-critic
        mods = list(pol.mlp_extractor.policy_net) + [pol.action_net]
        output = "clip"
    elif hasattr(pol, "actor") and hasattr(pol.actor, "latent_pi"):  # SAC
        mods = list(pol.actor.latent_pi) + [pol.actor.mu]
        output = "tanh"
    elif hasattr(pol, "actor") and hasattr(pol.actor, "mu"):  # TD3/DDPG: mu ends with Tanh
        mods = list(pol.actor.mu)
        output = "clip"
    else:
        raise ValueError("export_sb3: an MLP policy of PPO, A2C, SAC or TD3 is expected")
    act = "tanh"
    for m in mods:
        if isinstance(m, torch.nn.Linear):
            lin.append((m.weight.detach().cpu().numpy().T, m.bias.detach().cpu().numpy()))
        elif isinstance(m, torch.nn.ReLU):
            act = "relu"
    save_npz(path, lin, activation=act, output=output, obs_mean=obs_mean, obs_std=obs_std)


class _NpzPolicy:
    def __init__(self, path: Path):
        with np.load(path, allow_pickle=False) as z:
            keys = set(z.files)
            n = 0
            self.layers = []
            while f"w{n}" in keys:
                self.layers.append((z[f"w{n}"].astype(np.float64), z[f"b{n}"].astype(np.float64)))
                n += 1
            if not self.layers:
                raise ValueError("no layers w0, b0, ... in the file")
            self.activation = str(z["activation"]) if "activation" in keys else "tanh"
            self.output = str(z["output"]) if "output" in keys else "clip"
            self.mean = z["obs_mean"].astype(np.float64) if "obs_mean" in keys else None
            self.std = z["obs_std"].astype(np.float64) if "obs_std" in keys else None
        if self.activation not in ("tanh", "relu") or self.output not in ("clip", "tanh"):
            raise ValueError(f"activation {self.activation!r} / output {self.output!r} not supported")
        self.n_in, self.n_out = self.layers[0][0].shape[0], self.layers[-1][0].shape[1]

    def __call__(self, obs):
        x = obs
        if self.mean is not None:
            x = (x - self.mean) / self.std
        for k, (w, b) in enumerate(self.layers):
            x = x @ w + b
            if k < len(self.layers) - 1:
                x = np.tanh(x) if self.activation == "tanh" else np.maximum(x, 0.0)
        return np.tanh(x) if self.output == "tanh" else x


class _SB3Policy:
    def __init__(self, path: Path):
        try:
            import stable_baselines3 as sb3
        except ImportError:
            raise ValueError("a .zip policy needs stable-baselines3: pip install -e \".[rl]\" (or export it to "
                             ".npz with controllers.policy.export_sb3)") from None
        err = None
        for name in ("PPO", "SAC", "TD3", "A2C", "DDPG"):
            try:
                self.model = getattr(sb3, name).load(str(path), device="cpu")
                break
            except Exception as exc:  # the wrong algorithm class for this file
                err = exc
        else:
            raise ValueError(f"not a stable-baselines3 model: {err}")
        shp = self.model.observation_space.shape
        self.n_in = int(np.prod(shp)) if shp else None
        self.n_out = int(np.prod(self.model.action_space.shape))

    def __call__(self, obs):
        a, _ = self.model.predict(obs.astype(np.float32), deterministic=True)
        return np.asarray(a, dtype=np.float64).reshape(obs.shape[0], -1)


class _OnnxPolicy:
    def __init__(self, path: Path):
        try:
            import onnxruntime as ort
        except ImportError:
            raise ValueError("an .onnx policy needs onnxruntime (pip install onnxruntime)") from None
        self.sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        inp = self.sess.get_inputs()[0]
        self.name = inp.name
        self.n_in = inp.shape[-1] if isinstance(inp.shape[-1], int) else None
        self.n_out = None

    def __call__(self, obs):
        out = self.sess.run(None, {self.name: obs.astype(np.float32)})[0]
        return np.asarray(out, dtype=np.float64).reshape(obs.shape[0], -1)


_LOADERS = {".npz": _NpzPolicy, ".zip": _SB3Policy, ".onnx": _OnnxPolicy}
_CACHE: dict = {}


def load_policy(path: str):
    """The callable obs (batch, D) -> action (batch, n) of a policy file (cached per file and mtime)."""
    p = Path(path).expanduser()
    if not p.exists():
        raise ScenarioError(f"policy file not found: {path}", field="controller.params.path")
    loader = _LOADERS.get(p.suffix.lower())
    if loader is None:
        raise ScenarioError(f"policy file {path}: unknown format (use .npz, .zip or .onnx)", field="controller.params.path")
    key = (str(p.resolve()), p.stat().st_mtime_ns)
    if key not in _CACHE:
        try:
            _CACHE[key] = loader(p)
        except ValueError as exc:
            raise ScenarioError(f"policy file {path}: {exc}", field="controller.params.path") from None
    return _CACHE[key]


@CONTROLLERS.register("policy")
class Policy(Controller):
    """Trained policy (.npz MLP, stable-baselines3 .zip, .onnx) on the CPU: declared sensors in, command out."""

    Params = PolicyParams

    def __init__(self, p, ctx):
        n = ctx.n_cars
        paths = p.path if isinstance(p.path, list) else [p.path] * n
        self.groups: dict[str, list[int]] = {}
        for i, path in enumerate(paths):
            self.groups.setdefault(path, []).append(i)
        self.policies = {path: load_policy(path) for path in self.groups}
        self.layout = ctx.reading_layout()
        self.n_obs = sum(self.layout.values())
        for path, pol in self.policies.items():
            if pol.n_in is not None and pol.n_in != self.n_obs:
                raise ScenarioError(f"policy {path} takes {pol.n_in} observations; the scenario's sensors give "
                                    f"{self.n_obs} ({', '.join(f'{k}: {w}' for k, w in self.layout.items())})",
                                    field="controller.params.path")
            if pol.n_out is not None and pol.n_out != ctx.n_corners:
                raise ScenarioError(f"policy {path} gives {pol.n_out} actions; the model has {ctx.n_corners} "
                                    "corner(s)", field="controller.params.path")
        self.obs_scale = self._obs_scale(p.obs_scale, n)
        self.action_scale = self._action_scale(p.action_scale, ctx, n)
        super().__init__(p, ctx)

    def _obs_scale(self, s, n):
        if s is None:
            return np.ones((n, self.n_obs))
        a = np.asarray(s, dtype=float)
        if a.ndim == 2 and a.shape[0] == n:  # stacked per car
            a = a if a.shape[1] in (1, self.n_obs) else None
        elif a.size in (1, self.n_obs):
            a = a.reshape(1, -1)
        else:
            a = None
        if a is None:
            raise ScenarioError(f"obs_scale: give 1 or {self.n_obs} values", field="controller.params.obs_scale")
        return np.broadcast_to(a, (n, self.n_obs)).copy()

    def _action_scale(self, s, ctx, n):
        if s is not None:
            return np.broadcast_to(np.asarray(s, dtype=float).reshape(-1, 1), (n, 1)).copy()
        lim = command_limit(ctx.extra.get("actuator_params"))
        if lim is None:
            raise ScenarioError(f"actuator {ctx.actuator!r} has no command limit: set controller.params.action_scale",
                                field="controller.params.action_scale")
        return np.broadcast_to(np.asarray(lim, dtype=float).reshape(n, -1)[:, :1], (n, 1)).copy()

    def reset(self):
        super().reset()

    def step(self, t, y):
        n = self.ctx.n_cars
        obs = np.concatenate([np.asarray(y[name], dtype=float).reshape(n, -1) for name in self.layout], axis=1)
        obs = obs * self.obs_scale
        u = np.zeros((n, self.ctx.n_corners))
        for path, cars in self.groups.items():
            a = self.policies[path](obs[cars] if len(cars) < n else obs)
            u[cars] = np.clip(np.nan_to_num(a), -1.0, 1.0)
        return u * self.action_scale

    def signals(self):
        return {}
