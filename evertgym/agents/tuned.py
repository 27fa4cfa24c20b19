"""The tuned heuristic: the operator protocol with the best parameters of a small search.

``scripts/tune_operator.py`` searches the protocol's parameters on training scenes of an
env and writes ``agents/tuned_operator.json``; :func:`load_tuned` builds the policy from
that file (or from an explicit ``path``).
"""

from __future__ import annotations

import json
from pathlib import Path

from evertgym.agents.baselines import OperatorProtocol


def shipped_dir() -> Path:
    """The shipped ``agents/`` folder: the checkout's, else the installed ``evertgym.shipped_agents``."""
    repo = Path(__file__).resolve().parents[2] / "agents"
    if repo.is_dir():
        return repo
    from importlib.resources import files

    return Path(str(files("evertgym.shipped_agents")))


TUNED_PATH = shipped_dir() / "tuned_operator.json"


def load_tuned(path: str | Path | None = None) -> OperatorProtocol:
    """The operator protocol with the parameters of ``path`` (default: the shipped ``tuned_operator.json``)."""
    p = Path(path) if path else TUNED_PATH
    if not p.exists():
        raise ValueError(f"tuned heuristic file {str(p)!r} does not exist: run scripts/tune_operator.py")
    data = json.loads(p.read_text())
    policy = OperatorProtocol(**data["best"]["params"])
    policy.name = "tuned"
    return policy
