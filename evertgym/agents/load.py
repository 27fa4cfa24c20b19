"""Shipped agents from Python: the ``agents/`` folder, and trained policies by name or path.

The repository's ``agents/`` folder (installed as the package ``evertgym.shipped_agents``) holds
the training configs, the tuned heuristic's parameters and the small trained policies::

    import gymnasium as gym
    import evertgym
    from evertgym.agents import load_policy

    policy, env_id, env_kwargs = load_policy("colon_ppo_operator")
    env = gym.make(env_id, **env_kwargs)      # the observation the policy was trained on
    obs, info = env.reset(seed=0)
    policy.reset(env)
    obs, reward, terminated, truncated, info = env.step(policy.act(obs, info))

Loading a policy needs the ``rl`` extra (``pip install 'evertgym[rl]'``).
"""

from __future__ import annotations

from pathlib import Path

from evertgym._extras import require
from evertgym.agents.baselines import Policy
from evertgym.agents.policies import SB3Policy, resolve_policy_path


def require_rl(what: str) -> None:
    """Raise ``ImportError`` naming the ``rl`` extra when stable-baselines3 or PyTorch is missing."""
    require(what, "stable_baselines3", "torch")


def load_policy(name_or_path: str | Path, deterministic: bool | None = None,
                trust: bool = False, allow_engine_mismatch: bool = False) -> tuple[Policy, str | None, dict]:
    """A trained policy with the env id and env kwargs it was trained with.

    ``name_or_path`` is a shipped policy's name (:func:`shipped_policies`, e.g.
    ``"colon_ppo_operator"``), a run folder or a ``.zip``.  Returns ``(policy, env_id, env_kwargs)``:
    ``gym.make(env_id, **env_kwargs)`` gives the observation the policy expects
    (:func:`~evertgym.agents.policies.model_meta`: the ``<stem>_env.json`` beside the model,
    or a checkpoint's run ``config.json``; ``env_id`` is None without either).  The policy
    has the :class:`~evertgym.agents.baselines.Policy` interface (``reset(env)``,
    ``act(obs, info)``) and applies the model's VecNormalize statistics itself; its SB3
    model is ``policy.model``.  A model that is not a shipped policy loads only with
    ``trust=True`` (model files are code: :mod:`evertgym.agents.trust`).

    ``env_kwargs`` name the simulator engine the model was trained on (``sim_config["engine"]``),
    and ``policy.reset(env)`` refuses, in one line, an env on another engine: a model trained on
    the dynamic engine is not silently run on the quasi-static one.  ``allow_engine_mismatch=True``
    lets it run there.
    """
    require_rl("load_policy")
    path = resolve_policy_path(name_or_path)
    policy = SB3Policy(path, deterministic, trust=trust)
    env_id = policy.env_id
    if env_id is not None:
        _adopt_observation_space(policy.model, env_id, policy.env_kwargs)
    policy.check_engine = not allow_engine_mismatch
    env_kwargs = dict(policy.env_kwargs)
    sim = env_kwargs.get("sim_config")
    if policy.engine is not None and (sim is None or isinstance(sim, dict)):  # the engine named, not left to the default
        env_kwargs["sim_config"] = {**(sim or {}), "engine": policy.engine}
    return policy, env_id, env_kwargs


def _adopt_observation_space(model, env_id: str, env_kwargs: dict) -> None:
    """Give a model saved before 0.2.0 (observation bounds +-10) the env's true bounds, so
    ``model.set_env(env)`` (fine-tuning) passes SB3's space check; the values it sees are
    the same.  Only when the shapes agree: a real mismatch still fails there."""
    import gymnasium as gym

    from evertgym.env import register_envs

    register_envs()
    env = gym.make(env_id, **env_kwargs)
    space = env.observation_space
    env.close()
    if space.shape == model.observation_space.shape:
        model.observation_space = space
        model.policy.observation_space = space
