"""The tuned heuristic: the operator protocol with the best parameters of a small search.

``scripts/tune_operator.py`` searches the protocol's parameters on training scenes of an
env and writes ``agents/tuned_operator.json``; :func:`load_tuned` builds the policy from
that file (or from an explicit ``path``).
"""

from __future__ import annotations

import json
from pathlib import Path

from evertgym.agents.baselines import OperatorProtocol

TUNED_PATH = Path(__file__).resolve().parents[2] / "agents" / "tuned_operator.json"


def load_tuned(path: str | Path | None = None) -> OperatorProtocol:
    """The tuned operator protocol from ``path`` (default: the shipped ``tuned_operator.json``,
    from the checkout or the installed wheel)."""
    from evertgym.agents.load import shipped_dir

    p = Path(path) if path else shipped_dir() / TUNED_PATH.name
    if not p.exists():
        raise ValueError(f"tuned heuristic file {str(p)!r} does not exist: run scripts/tune_operator.py")
    data = json.loads(p.read_text())
    policy = OperatorProtocol(**data["best"]["params"])
    policy.name = "tuned"
    return policy
