"""``evertgym bench env --against REV``: two builds side by side (no timings asserted)."""

import json
import subprocess
import sys

import pytest

from evertgym.bench.against import BuildError, bench_against, format_against


@pytest.mark.slow  # 70-140 s: the revision's tree compiles its own quasi-static kernel
def test_against_head_lays_out_the_revision_and_reports_both_builds():
    result = bench_against("HEAD", ["evertgym/UBend-v0"], steps=3, repeats=2)
    (row,) = result["rows"]
    assert row["env_id"] == "evertgym/UBend-v0"
    assert len(row["runs"]) == len(row["runs_against"]) == 2
    assert row["steps_per_s"] == max(row["runs"]) and row["steps_per_s_against"] == max(row["runs_against"])
    assert row["ratio"] == pytest.approx(row["steps_per_s"] / row["steps_per_s_against"])
    assert len(result["against_commit"]) == 40
    text = "\n".join(format_against(result))
    assert "working tree steps/s" in text and result["against_commit"][:12] in text


def test_an_unknown_revision_is_one_line():
    with pytest.raises(BuildError, match="--against = 'no-such-rev' is not a commit"):
        bench_against("no-such-rev", ["evertgym/UBend-v0"], steps=1, repeats=1)


@pytest.mark.parametrize("argv, message", [
    (["--against", "no-such-rev"], "--against = 'no-such-rev' is not a commit"),
    (["--repeats", "0", "--against", "HEAD"], "--repeats = 0 is out of range"),
    (["--steps", "0"], "--steps = 0 is out of range"),
    (["--env", "evertgym/Nope-v0"], "--env = 'evertgym/Nope-v0' is not an evertgym env"),
])
def test_bench_env_rejects_bad_input_in_one_line(argv, message):
    done = subprocess.run([sys.executable, "-m", "evertgym.cli", "bench", "env", *argv], capture_output=True, text=True)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr


def test_bench_env_json_keeps_its_keys():
    done = subprocess.run([sys.executable, "-m", "evertgym.cli", "bench", "env", "--steps", "2", "--env", "evertgym/UBend-v0",
                           "--json"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    (row,) = json.loads(done.stdout)["rows"]
    assert set(row) >= {"env_id", "steps_per_s", "sim_seconds_per_step", "steps", "wall_s"}
