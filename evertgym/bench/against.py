"""Env throughput of two builds side by side: a git revision against the working tree.

``evertgym bench env --against REV`` lays the revision's tracked files out in a temporary
directory (``git archive``), starts one long-lived Python process per build with that
build's ``evertgym`` first on ``sys.path``, pins both to the same CPU, and then alternates
short runs between them (A, B, B, A, ...), keeping the best steps/s of each build per env
id.  A load spike on the shared machine then hits both builds alike, and the ratio of the
best runs is what the comparison reports: absolute steps/s move by 1.5x between runs on a
shared machine, ratios measured this way do not.

Each run is ``steps`` env steps of uniform random actions with a fixed seed after a reset
(the same actions for both builds), timed without the env's construction; both builds use
the Python, pymunk and numpy of the process that runs the benchmark.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from collections.abc import Sequence
from pathlib import Path

#: The child: reads ``env_id steps seed`` lines, answers one JSON line per run.
_CHILD = r"""
import json, os, sys, time
tree, cpu = sys.argv[1], int(sys.argv[2])
kwargs = json.loads(sys.argv[3]) if len(sys.argv) > 3 else {}
sys.path.insert(0, tree)
if hasattr(os, "sched_setaffinity"):
    os.sched_setaffinity(0, {cpu})
import numpy as np
import gymnasium as gym
import evertgym  # registers the envs (every build since 199a1c1 does on import)
origin = os.path.realpath(evertgym.__file__)
if not origin.startswith(os.path.realpath(tree)):
    raise SystemExit(f"evertgym imported from {origin}, not from {tree}")
envs = {}
print(json.dumps({"ready": origin}), flush=True)
for line in sys.stdin:
    env_id, steps, seed = line.split()
    steps, seed = int(steps), int(seed)
    env = envs.get(env_id)
    if env is None:
        env = envs[env_id] = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        if term or trunc:
            env.reset()
    wall = time.perf_counter() - t0
    print(json.dumps({"env_id": env_id, "steps": steps, "wall_s": wall}), flush=True)
"""


class BuildError(RuntimeError):
    """The revision could not be laid out or its build did not start."""


def repo_root() -> Path:
    """The git work tree holding the imported ``evertgym`` (raises :class:`BuildError` if none)."""
    here = Path(__file__).resolve().parents[2]  # evertgym/bench/against.py -> the tree holding evertgym/
    done = subprocess.run(["git", "-C", str(here), "rev-parse", "--show-toplevel"], capture_output=True, text=True)
    if done.returncode != 0:
        raise BuildError(f"--against needs evertgym imported from a git checkout; {here} is not one")
    return Path(done.stdout.strip())


def export_revision(rev: str, root: Path, into: Path) -> str:
    """Write the tracked files of ``rev`` into ``into``; returns the full commit id."""
    done = subprocess.run(["git", "-C", str(root), "rev-parse", "--verify", "--quiet", f"{rev}^{{commit}}"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise BuildError(f"--against = {rev!r} is not a commit of {root}: allowed a git revision (hash, tag, branch)")
    commit = done.stdout.strip()
    tar = subprocess.run(["git", "-C", str(root), "archive", "--format=tar", commit], capture_output=True, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
        tf.extractall(into, filter="data")
    return commit


class _Build:
    """One build's long-lived benchmark process."""

    def __init__(self, name: str, tree: Path, cpu: int, env_kwargs: dict | None = None) -> None:
        self.name = name
        env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
        env.pop("PYTHONPATH", None)
        args = [sys.executable, "-c", _CHILD, str(tree), str(cpu)] + ([json.dumps(env_kwargs)] if env_kwargs else [])
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
        first = self.proc.stdout.readline() if self.proc.stdout else ""
        if not first:
            err = self.proc.stderr.read() if self.proc.stderr else ""
            raise BuildError(f"the {name} build did not start: {err.strip().splitlines()[-1:] or 'no output'}")
        self.origin = json.loads(first)["ready"]

    def run(self, env_id: str, steps: int, seed: int) -> float:
        """Steps per second of one run."""
        assert self.proc.stdin and self.proc.stdout
        self.proc.stdin.write(f"{env_id} {steps} {seed}\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            err = self.proc.stderr.read() if self.proc.stderr else ""
            raise BuildError(f"the {self.name} build failed on {env_id}: {err.strip().splitlines()[-1:] or 'no output'}")
        out = json.loads(line)
        return out["steps"] / out["wall_s"]

    def close(self) -> None:
        if self.proc.stdin:
            self.proc.stdin.close()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def bench_against(rev: str, env_ids: Sequence[str], steps: int = 200, repeats: int = 5, seed: int = 0,
                  progress=None, sim: dict | None = None, env_kwargs: dict | None = None) -> dict:
    """Best steps/s of ``rev`` and of the working tree per env id, and their ratio.

    ``repeats`` runs of ``steps`` env steps per build and id, alternating builds (ABBA...)
    on one CPU (the lowest this process may use).  ``progress``, if given, is called after
    each run.  ``sim``: SimConfig overrides for the working tree's envs only (``sim_config``; e.g.
    its quasi-static engine against the revision's default); ``env_kwargs``: other env kwargs for the
    working tree's envs only (e.g. ``{"variation": "off"}``: the physics of a revision before the bend
    model, to compare the code at equal physics).  Returns ``{"against",
    "against_commit", "tree", "cpu", "steps", "repeats", "sim",
    "rows": [{"env_id", "steps_per_s_against", "steps_per_s", "ratio", "runs_against",
    "runs"}]}``.
    """
    root = repo_root()
    cpu = min(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 0
    with tempfile.TemporaryDirectory(prefix="evertgym-against-") as tmp:
        commit = export_revision(rev, root, Path(tmp))
        builds = {"against": _Build(f"{rev} ({commit[:12]})", Path(tmp), cpu),
                  "tree": _Build("working tree", root, cpu, {**({"sim_config": dict(sim)} if sim else {}), **(env_kwargs or {})} or None)}
        try:
            runs: dict[tuple[str, str], list[float]] = {}
            for env_id in env_ids:
                for k in range(repeats):
                    order = ("against", "tree") if k % 2 == 0 else ("tree", "against")
                    for side in order:
                        runs.setdefault((side, env_id), []).append(builds[side].run(env_id, steps, seed + k))
                        if progress is not None:
                            progress()
        finally:
            for b in builds.values():
                b.close()
    rows = []
    for env_id in env_ids:
        a, t = max(runs[("against", env_id)]), max(runs[("tree", env_id)])
        rows.append({"env_id": env_id, "steps_per_s_against": a, "steps_per_s": t, "ratio": t / a,
                     "runs_against": runs[("against", env_id)], "runs": runs[("tree", env_id)]})
    return {"against": rev, "against_commit": commit, "tree": str(root), "cpu": cpu, "steps": steps,
            "repeats": repeats, "sim": dict(sim or {}), "env_kwargs": dict(env_kwargs or {}), "rows": rows}


def format_against(result: dict) -> list[str]:
    """The comparison as a text table."""
    rev = f"{result['against']} ({result['against_commit'][:12]})"
    sim = f"; working tree with sim_config {json.dumps(result['sim'])}" if result.get("sim") else ""
    if result.get("env_kwargs"):
        sim += f"; working tree with env kwargs {json.dumps(result['env_kwargs'])}"
    lines = [f"side by side on CPU {result['cpu']}: best of {result['repeats']} alternating runs of {result['steps']} env steps{sim}",
             f"{'env_id':26s} {rev + ' steps/s':>28s} {'working tree steps/s':>21s} {'ratio':>6s}"]
    for r in result["rows"]:
        lines.append(f"{r['env_id']:26s} {r['steps_per_s_against']:>28.0f} {r['steps_per_s']:>21.0f} {r['ratio']:>5.2f}x")
    return lines
