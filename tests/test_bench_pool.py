"""The backend benchmark (evertgym bench pool): its rows, not its timings."""

import json

import pytest

from evertgym.bench.pool import bench_pool, busy_specs, busy_trial
from evertgym.cli import main


def test_busy_trial_is_deterministic_and_does_the_asked_work():
    a, b = busy_specs(2, 1000)
    assert busy_trial(a) == busy_trial(b)
    assert busy_trial(busy_specs(1, 1000)[0]) != busy_trial(busy_specs(1, 1001)[0])


def test_bench_pool_runs_every_trial_on_every_backend_and_measures_against_one_worker():
    result = bench_pool(trials=3, trial_s=0.01, dask=False)
    rows = {(r["backend"], r["workers"]): r for r in result["rows"]}
    assert set(rows) == {("serial", 1), ("process", 1), ("process", 2)}
    assert all(r["trials"] == 3 and r["wall_s"] > 0 for r in rows.values())
    assert rows[("process", 1)]["speedup_vs_1"] == pytest.approx(1.0)
    for r in rows.values():
        assert r["trials_per_s"] == pytest.approx(r["trials"] / r["wall_s"], rel=0.01)
        assert r["speedup_vs_1"] == pytest.approx(rows[("process", 1)]["wall_s"] / r["wall_s"], rel=0.01)


@pytest.mark.parametrize("kwargs, field", [({"trials": 0}, "trials"), ({"trial_s": 0.0}, "trial_s"), ({"trial_s": 100.0}, "trial_s")])
def test_bench_pool_rejects_bad_input_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        bench_pool(dask=False, **kwargs)


def test_bench_pool_cli_json(capsys):
    assert main(["bench", "pool", "--trials", "2", "--trial-s", "0.01", "--no-dask", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) >= {"cpus", "trial", "rows"}
    assert [r["backend"] for r in out["rows"]] == ["serial", "process", "process"]
    assert main(["bench", "pool", "--trials", "0", "--no-dask"]) != 0
    assert "--trials" in capsys.readouterr().err
