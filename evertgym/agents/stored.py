"""Held-out episodes read back from evaluation stores (``evertgym eval --db``, ``evertgym baselines --db``).

Every finished episode is a trial record keyed by its policy's label (the store's group), the env id (the scene's
family), the env kwargs it was played with (the scene's params) and its seed; these helpers pick one env's held-out
episodes out of a store, for the paired comparisons of ``evertgym paired`` and ``evertgym headroom``.
"""

from __future__ import annotations

import json
from pathlib import Path

from evertgym.env import preset_kwargs
from evertgym.env.eversion_env import HELD_OUT_SEED_BASE, VALIDATION_SEED_BASE
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
                      group: str | None = None, seed_base: int = HELD_OUT_SEED_BASE) -> dict[str, dict[int, dict]]:
    """Per policy label (only ``group`` if given): its first ``episodes`` held-out episodes of ``env_id`` played with
    exactly ``env_kwargs``, as {seed: trial result}; ``seed_base`` :data:`VALIDATION_SEED_BASE` reads the
    validation episodes (``evertgym eval --validation``) instead.  A label whose episodes were played by two
    versions of the policy (another engine, model file or tuned parameters) raises a one-line ValueError: they are
    not one policy."""
    seeds = list(range(seed_base, seed_base + episodes))
    where: dict = {"seed": seeds} if group is None else {"seed": seeds, "group": group}
    out: dict[str, dict[int, dict]] = {}
    versions: dict[str, set[str]] = {}
    with ResultStore(db) as store:
        for r in store.results(**where):
            if r.spec.scene["family"] == env_id and r.spec.scene["params"] == env_kwargs:
                out.setdefault(r.spec.group, {})[r.spec.seed] = r.result
                version = {k: v for k, v in r.spec.scene.items() if k not in ("seed", "params", "family")}
                versions.setdefault(r.spec.group, set()).add(json.dumps(version, sort_keys=True))
    for label, found in versions.items():
        if len(found) > 1:
            raise ValueError(f"store {str(db)!r} holds episodes of {label!r} from {len(found)} versions of it "
                             f"({'; '.join(sorted(found))}): allowed one; evaluate each version into its own store (--db)")
    return out


def policy_episodes(flag: str, spec: str, env_id: str, episodes: int, env_kwargs: dict,
                    seed_base: int = HELD_OUT_SEED_BASE) -> tuple[str, str, dict[int, dict]]:
    """``STORE:POLICY`` (a flag's value) split into the store and the policy's label, with that policy's held-out
    episodes (:func:`held_out_episodes`).  A ValueError of one line names the flag when the label is missing."""
    db, _, group = spec.partition(":")
    if not group:
        raise ValueError(f"{flag} = {spec!r}: expected STORE:POLICY (the policy's label in the store)")
    return db, group, held_out_episodes(db, env_id, episodes, env_kwargs, group=group, seed_base=seed_base).get(group, {})


def paired_difference(env_id: str, first: str, second: str, key: str = "max_contact_force_n", episodes: int = 200,
                      env_kwargs: dict | None = None, seed_base: int = HELD_OUT_SEED_BASE) -> list[str]:
    """Two policies on the same held-out episodes (the validation episodes with ``seed_base``
    :data:`VALIDATION_SEED_BASE`), read from evaluation stores (``STORE:POLICY`` each, as :func:`policy_episodes`
    takes them): over the episodes both have, the two means of the per-episode figure ``key``, the mean difference
    (second minus first) with its normal 95% interval, the Wilcoxon signed-rank p-value and in how many episodes the
    second is lower; then both successes with the exact McNemar test on the discordant episodes.  Returns the printed
    lines; a one-line ``ValueError`` for bad input or fewer than 2 shared episodes."""
    import math

    import numpy as np
    from scipy import stats

    kwargs = default_env_kwargs(env_id) if env_kwargs is None else env_kwargs
    ra = policy_episodes("--a", first, env_id, episodes, kwargs, seed_base)[2]
    rb = policy_episodes("--b", second, env_id, episodes, kwargs, seed_base)[2]
    seeds = sorted(set(ra) & set(rb))
    if len(seeds) < 2:
        which = " (validation episodes)" if seed_base == VALIDATION_SEED_BASE else ""
        raise ValueError(f"only {len(seeds)} episodes in both stores for {env_id} with env kwargs {json.dumps(kwargs)}{which}")
    a = {s: float(ra[s][key]) for s in seeds}
    b = {s: float(rb[s][key]) for s in seeds}
    d = np.array([b[s] - a[s] for s in seeds])
    half = 1.96 * d.std(ddof=1) / math.sqrt(len(d))
    sa = [bool(ra[s]["success"]) for s in seeds]
    sb = [bool(rb[s]["success"]) for s in seeds]
    only_a = sum(x and not y for x, y in zip(sa, sb))
    only_b = sum(y and not x for x, y in zip(sa, sb))
    p = stats.binomtest(only_a, only_a + only_b, 0.5).pvalue if only_a + only_b else 1.0
    return [
        f"{env_id}, {len(seeds)} episodes in both, {key}: first {np.mean(list(a.values())):.4f}, second {np.mean(list(b.values())):.4f}",
        f"second - first: {d.mean():+.4f}, 95% interval [{d.mean() - half:+.4f}, {d.mean() + half:+.4f}], "
        f"Wilcoxon p = {stats.wilcoxon(d).pvalue:.2g}, second lower in {(d < 0).sum()} of {len(d)}",
        f"success: first {sum(sa)}/{len(seeds)}, second {sum(sb)}/{len(seeds)}; passed by the first only "
        f"{only_a}, by the second only {only_b}, exact McNemar p = {p:.2g}",
    ]
