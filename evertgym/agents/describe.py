"""Baseline policies by description: ``"operator"``, ``"cycle:low_kpa=0,high_kpa=3"``, ``{"name": ...}``.

The spelling every command and config uses for a rule; :mod:`evertgym.agents.policies` adds trained models.
"""

from __future__ import annotations

from evertgym.agents.baselines import BASELINES, Policy
from evertgym.agents.tuned import load_tuned


def make_baseline(name: str, **kwargs) -> Policy:
    """A baseline policy by name (``constant``, ``operator``, ``cycle``, ``deflate``, ``tuned``) with its parameters
    (``tuned`` takes ``env_id``, the env whose tuned parameters to load, or a ``path``)."""
    if name == "tuned":
        return load_tuned(**kwargs)
    if name not in BASELINES:
        raise ValueError(f"unknown baseline {name!r}: allowed {sorted(BASELINES) + ['tuned']}")
    try:
        return BASELINES[name](**kwargs)
    except TypeError as e:  # an unknown parameter: name it, as for any bad field
        raise ValueError(f"policy {name!r}: {e}") from None


def _parse_params(desc: str, name: str, rest: str) -> dict:
    """``"low_kpa=0,high_kpa=3"`` -> ``{"name": name, "low_kpa": 0.0, "high_kpa": 3.0}`` (numbers only)."""
    out: dict = {"name": name}
    for kv in rest.split(","):
        k, eq, v = (x.strip() for x in kv.partition("="))
        if not (k and eq):
            raise ValueError(f"policy = {desc!r}: {kv.strip()!r} is not a parameter: allowed name:key=value,key=value")
        if k in out:
            raise ValueError(f"policy = {desc!r}: {k} is given twice: allowed each parameter once")
        try:
            out[k] = float(v)
        except ValueError:
            raise ValueError(f"policy = {desc!r}: {k} must be a number (got {v!r})") from None
    return out


def policy_desc(desc: dict | str) -> dict:
    """A policy description as a dict with a ``name``: ``"operator"`` -> ``{"name": "operator"}``,
    ``"cycle:low_kpa=0,high_kpa=3,period_s=1"`` -> ``{"name": "cycle", "low_kpa": 0.0, ...}``
    (the CLI's spelling of a baseline with parameters: numbers, kPa/s/mm as the names say),
    ``"model.zip"`` (optionally ``"model.zip:deterministic"`` / ``":stochastic"``) ->
    ``{"name": "agent", "path": ..., ...}``; dicts pass through (copied)."""
    if isinstance(desc, str):
        path, _, mode = desc.partition(".zip:")
        if mode:  # "model.zip:deterministic" or "model.zip:stochastic"
            if mode not in ("deterministic", "stochastic"):
                raise ValueError(f"policy = {desc!r}: the mode after '.zip:' must be 'deterministic' or 'stochastic'")
            return {"name": "agent", "path": path + ".zip", "deterministic": mode == "deterministic"}
        if desc.endswith(".zip"):
            return {"name": "agent", "path": desc}
        name, colon, rest = desc.partition(":")
        if colon and "=" in rest:  # "constant:pressure_kpa=3"
            return _parse_params(desc, name.strip(), rest)
        return {"name": name.strip() if colon and not rest.strip() else desc}
    if not isinstance(desc, dict):
        raise ValueError(f"policy = {desc!r}: allowed a name, a model path or a dict with a name")
    return dict(desc)


def for_env(desc: dict | str, env_id: str) -> dict:
    """The description of ``desc`` as evaluated on ``env_id``: ``tuned`` without a ``path``
    or ``env_id`` of its own takes the parameters tuned on ``env_id`` (its training scenes);
    every other description is unchanged."""
    d = policy_desc(desc)
    if d.get("name") == "tuned" and "path" not in d and "env_id" not in d:
        d["env_id"] = env_id
    return d
