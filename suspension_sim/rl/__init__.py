"""Reinforcement learning on the simulator: Gymnasium environments (one car, and N cars as one compiled
ensemble) and the ``policy`` controller that runs a trained agent in any scenario.

``import suspension_sim`` registers ``suspension_sim/QuarterCar-v0``, ``HalfCar-v0`` and ``FullCar-v0``
with Gymnasium (:func:`register_envs`); ``gymnasium.make_vec(id, num_envs=N,
vectorization_mode="vector_entry_point")`` gives the compiled ensemble.  See :mod:`.env` for the
observation, action, reward and termination, and ``docs/learning.md``.
"""
from __future__ import annotations

ENV_NAMESPACE = "suspension_sim"


def register_envs() -> None:
    """Register the preset environments with Gymnasium (once; a no-op without Gymnasium)."""
    try:
        from gymnasium.envs.registration import register, registry
    except ImportError:  # pragma: no cover - gymnasium is a default dependency
        return
    from .presets import ENV_IDS

    for env_id, model in ENV_IDS.items():
        full = f"{ENV_NAMESPACE}/{env_id}"
        if full in registry:
            continue
        register(id=full, entry_point=f"suspension_sim.rl.env:{model}_env",
                 vector_entry_point=f"suspension_sim.rl.env:{model}_vector_env",
                 disable_env_checker=False)


def __getattr__(name):  # lazy: importing gymnasium and the env module only when used
    if name in ("SuspensionEnv", "SuspensionVectorEnv", "Reward", "make_gym_env", "WkFilter"):
        from . import env

        return getattr(env, name)
    raise AttributeError(name)
