"""Held-out episodes read back from evaluation stores (``evertgym eval --db``, ``scripts/baseline_table.py --db``).

Every finished episode is a trial record keyed by its policy's label (the store's group), the env id (the scene's
family), the env kwargs it was played with (the scene's params) and its seed; these helpers pick one env's held-out
episodes out of a store, for the paired comparisons of ``scripts/paired_difference.py`` and ``scripts/headroom.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

from evertgym.env import preset_kwargs
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE
from evertgym.scoring.store import ResultStore

#: the randomised regulator lag (s) the shipped policies were evaluated under
RANDOMISED_LAG = {"regulator_tau_s": [0.1, 0.6]}


def default_env_kwargs(env_id: str) -> dict:
    """The env kwargs the held-out tables were played with: the randomised lag, less what the id's preset draws
    itself (TortuousHard-v0 draws the lag: ``{}``).  A ValueError names an unknown id."""
    preset = preset_kwargs(env_id)
    return {k: v for k, v in RANDOMISED_LAG.items() if k not in preset}


def parse_env_kwargs(flag: str, text: str | None, env_id: str) -> dict:
    """``--env-kwargs`` as given (a JSON object), or :func:`default_env_kwargs` when absent.  A ValueError of one
    line names the flag, the value and what is allowed."""
    if text is None:
        try:
            return default_env_kwargs(env_id)
        except ValueError as e:
            raise ValueError(f"--env = {env_id!r} is not allowed: {e}") from None
    try:
        kwargs = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{flag} = {text!r} is not JSON ({e.msg}): allowed a JSON object of env kwargs") from None
    if not isinstance(kwargs, dict):
        raise ValueError(f"{flag} = {text!r} is not allowed: a JSON object of env kwargs")
    return kwargs


def held_out_episodes(db: str | Path, env_id: str, episodes: int, env_kwargs: dict,
                      group: str | None = None) -> dict[str, dict[int, dict]]:
    """Per policy label (only ``group`` if given): its first ``episodes`` held-out episodes of ``env_id`` played with
    exactly ``env_kwargs``, as {seed: trial result}."""
    seeds = list(range(HELD_OUT_SEED_BASE, HELD_OUT_SEED_BASE + episodes))
    where: dict = {"seed": seeds} if group is None else {"seed": seeds, "group": group}
    out: dict[str, dict[int, dict]] = {}
    with ResultStore(db) as store:
        for r in store.results(**where):
            if r.spec.scene["family"] == env_id and r.spec.scene["params"] == env_kwargs:
                out.setdefault(r.spec.group, {})[r.spec.seed] = r.result
    return out


def policy_episodes(flag: str, spec: str, env_id: str, episodes: int, env_kwargs: dict) -> tuple[str, str, dict[int, dict]]:
    """``STORE:POLICY`` (a flag's value) split into the store and the policy's label, with that policy's held-out
    episodes (:func:`held_out_episodes`).  A ValueError of one line names the flag when the label is missing."""
    db, _, group = spec.partition(":")
    if not group:
        raise ValueError(f"{flag} = {spec!r}: expected STORE:POLICY (the policy's label in the store)")
    return db, group, held_out_episodes(db, env_id, episodes, env_kwargs, group=group).get(group, {})
