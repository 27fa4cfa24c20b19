"""Scoring framework: trial identity, the append-only store, Wilson intervals and summaries,
and the resumable runner on the serial, process-pool and Dask backends (fake trials)."""

import hashlib
import json
import os
import pickle
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _fake_trial import crashing_trial, failing_trial, fake_trial, invalid_trial, make_specs
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import binomtest, norm

from evertgym.scoring import (
    ResultStore,
    TrialRecord,
    TrialResultError,
    TrialsFailed,
    TrialSpec,
    TrialSpecError,
    check_result,
    compare_rates,
    newcombe_interval,
    run_trials,
    summarize,
    wilson_interval,
)

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent

SPEC_FIELDS = dict(
    design={"tube": {"length_mm": 600.0}},
    design_name="bare",
    scene={"family": "ubend", "params": {"radius_mm": 25.0}, "seed": None},
    policy={"name": "constant", "pressure_kpa": 3.0},
    seed=7,
    index=0,
    group="r25",
)


def rows(path):
    """(key, meta run_id) of every stored row, read with a separate connection."""
    with sqlite3.connect(path) as db:
        return [(k, json.loads(m)["run_id"]) for k, m in db.execute("SELECT key, meta_json FROM trials")]


# ---------------------------------------------------------------- trial identity


def test_key_is_sha256_of_canonical_json_and_ignores_dict_order():
    spec = TrialSpec(**SPEC_FIELDS)
    canonical = (
        '{"design":{"tube":{"length_mm":600.0}},"design_name":"bare","group":"r25","index":0,'
        '"policy":{"name":"constant","pressure_kpa":3.0},'
        '"scene":{"family":"ubend","params":{"radius_mm":25.0},"seed":null},"seed":7}'
    )
    assert spec.key == hashlib.sha256(canonical.encode()).hexdigest()
    # pinned: changing the canonical form would orphan every stored result
    assert spec.key == "658c860a670e560dacf7e4a470a8421ec368f7a6541a5644f3cc0c3b35793ffa"
    reordered = dict(SPEC_FIELDS, policy={"pressure_kpa": 3.0, "name": "constant"})
    assert TrialSpec(**reordered).key == spec.key
    assert TrialSpec(**dict(SPEC_FIELDS, seed=8)).key != spec.key
    assert TrialSpec(**dict(SPEC_FIELDS, index=1)).key != spec.key
    episode = dict(SPEC_FIELDS["scene"], episode={"max_s": 20.0})  # extra scene keys are part of the trial
    assert TrialSpec(**dict(SPEC_FIELDS, scene=episode)).key != spec.key
    assert TrialSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec
    clone = pickle.loads(pickle.dumps(spec))
    assert clone == spec and clone.key == spec.key and len({spec, clone}) == 1


def test_spec_deep_copies_its_dicts_and_converts_numpy():
    design = {"tube": {"length_mm": 600.0}}
    spec = TrialSpec(**dict(SPEC_FIELDS, design=design, seed=np.int64(7)))
    key = spec.key
    design["tube"]["length_mm"] = 1.0
    assert spec.design == {"tube": {"length_mm": 600.0}} and spec.key == key
    assert type(spec.seed) is int and spec == TrialSpec(**SPEC_FIELDS)


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("seed", -1, "seed = -1 is not allowed: allowed an integer in [0, "),
        ("seed", 1.5, "seed = 1.5"),
        ("seed", True, "seed = True"),
        ("index", 2**63, "index = 9223372036854775808"),
        ("design_name", "", "design_name = ''"),
        ("group", None, "group = None"),
        ("design", [], "design = [] is not allowed: allowed a dict"),
        ("design", {"length_mm": float("nan")}, "design = {'length_mm': nan} is not JSON data"),
        ("scene", {"family": "ubend", "params": {}}, "lacks keys ['seed']: allowed a dict with family, params, seed"),
        ("scene", {"family": "ubend", "params": {}, "seed": -2}, "scene.seed = -2"),
        ("scene", {"family": "", "params": {}, "seed": 1}, "scene.family = ''"),
        ("policy", {"pressure_kpa": 3.0}, "policy.name = None"),
    ],
)
def test_spec_validation_names_the_field_and_allowed_values(field, value, message):
    with pytest.raises(TrialSpecError) as err:
        TrialSpec(**dict(SPEC_FIELDS, **{field: value}))
    assert message in str(err.value)


def test_check_result_converts_numpy_and_names_bad_keys():
    out = check_result(
        {"success": np.bool_(True), "time_s": np.float32(2.5), "peak_pressure_kpa": 3, "max_contact_force_n": 0.5,
         "stall_position_mm": None, "trace": np.arange(3)}
    )
    assert out == {"success": True, "time_s": 2.5, "peak_pressure_kpa": 3.0, "max_contact_force_n": 0.5,
                   "stall_position_mm": None, "trace": [0, 1, 2]}
    assert type(out["success"]) is bool and type(out["peak_pressure_kpa"]) is float
    good = dict(out)
    with pytest.raises(TrialResultError, match=r"lacks required keys \['success'\]"):
        check_result({k: v for k, v in good.items() if k != "success"})
    with pytest.raises(TrialResultError, match="time_s = nan is not allowed: allowed a finite number"):
        check_result(dict(good, time_s=float("nan")))
    with pytest.raises(TrialResultError, match="success = 1 is not allowed: allowed a bool"):
        check_result(dict(good, success=1))
    with pytest.raises(TrialResultError, match="peak_pressure_kpa = None"):
        check_result(dict(good, peak_pressure_kpa=None))
    with pytest.raises(TrialResultError, match="is not JSON data"):
        check_result(dict(good, extra=object()))


# ---------------------------------------------------------------- Wilson intervals


@pytest.mark.parametrize(
    "k, n, lo, hi",
    # Newcombe (1998), Stat. Med. 17:857, Table I, method 3 (Wilson score, no continuity correction)
    [(81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718)],
)
def test_wilson_matches_newcombes_published_values(k, n, lo, hi):
    assert wilson_interval(k, n) == pytest.approx((lo, hi), abs=6e-5)


@pytest.mark.parametrize("k", [0, 7, 12])
def test_wilson_matches_scipy_for_twelve_trials(k):
    z = norm.ppf(0.975)
    ref = binomtest(k, 12).proportion_ci(confidence_level=0.95, method="wilson")
    assert wilson_interval(k, 12, z=z) == pytest.approx((ref.low, ref.high), abs=1e-12)
    assert wilson_interval(k, 12) == pytest.approx((ref.low, ref.high), abs=2e-5)


def test_wilson_known_values_for_twelve_trials():
    # at 0/n and n/n the outer bound is z^2 / (n + z^2) from the end: 3.8416 / 15.8416
    assert wilson_interval(0, 12) == (0.0, pytest.approx(3.8416 / 15.8416, abs=1e-15))
    assert wilson_interval(12, 12) == (pytest.approx(12 / 15.8416, abs=1e-15), 1.0)
    assert wilson_interval(7, 12) == pytest.approx((0.31951, 0.80674), abs=1e-5)


@pytest.mark.parametrize(
    "a, b, d, lo, hi",
    # Newcombe (1998), Stat. Med. 17:873, Table II, method 10 (hybrid score, no continuity correction)
    [((56, 70), (48, 80), 0.2, 0.0524, 0.3339), ((9, 10), (3, 10), 0.6, 0.1705, 0.8090), ((6, 7), (2, 7), 4 / 7, 0.0582, 0.8062),
     ((5, 56), (0, 29), 5 / 56, -0.0381, 0.1926), ((0, 10), (0, 20), 0.0, -0.1611, 0.2775), ((10, 10), (0, 20), 1.0, 0.6791, 1.0)],
)
def test_newcombe_difference_matches_the_published_values(a, b, d, lo, hi):
    assert newcombe_interval(*a, *b) == pytest.approx((d, lo, hi), abs=6e-5)


def test_a_verdict_names_a_winner_only_when_the_interval_excludes_zero():
    win = compare_rates("banded", 56, 70, "bare", 48, 80)
    assert win["winner"] == "banded" and win["verdict"].startswith("banded succeeds more often than bare")
    lose = compare_rates("bare", 48, 80, "banded", 56, 70)
    assert lose["winner"] == "banded" and lose["difference"] == pytest.approx(-0.2) and lose["ci_hi"] < 0
    tie = compare_rates("a", 5, 56, "b", 0, 29)
    assert tie["winner"] is None and tie["verdict"].startswith("no clear winner between a and b")
    with pytest.raises(ValueError, match="successes = 3 is out of range"):
        newcombe_interval(3, 2, 0, 2)


@given(st.integers(1, 500).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_wilson_interval_contains_the_estimate_and_narrows_with_z(kn):
    k, n = kn
    lo, hi = wilson_interval(k, n)
    assert 0.0 <= lo <= k / n <= hi <= 1.0
    lo90, hi90 = wilson_interval(k, n, z=1.645)
    assert lo <= lo90 + 1e-12 and hi90 <= hi + 1e-12


@pytest.mark.parametrize(
    "args, message",
    [((0, 0), "n = 0 is out of range"), ((5, 4), r"successes = 5 is out of range: allowed an integer in \[0, 4\]"),
     ((-1, 4), "successes = -1"), ((1, 4, 0.0), "z = 0.0 is out of range")],
)
def test_wilson_rejects_bad_counts(args, message):
    with pytest.raises(ValueError, match=message):
        wilson_interval(*args)


# ---------------------------------------------------------------- summaries


def record(design_name, group, success, time_s, stall=None, radius=25.0, index=0):
    spec = TrialSpec(**dict(SPEC_FIELDS, design_name=design_name, group=group, index=index,
                            scene={"family": "ubend", "params": {"radius_mm": radius}, "seed": None}))
    result = {"success": success, "time_s": time_s, "peak_pressure_kpa": 2.0 * time_s,
              "max_contact_force_n": 0.1 * time_s, "stall_position_mm": stall}
    return TrialRecord(spec, result, {}, None, "")


def test_summarize_groups_success_rates_and_none_safe_medians():
    recs = [
        record("b30", "r25", True, 10.0, index=0),
        record("b30", "r25", True, 20.0, index=1),
        record("b30", "r30", False, 40.0, stall=300.0, radius=30.0, index=2),
        record("bare", "r25", False, 30.0, stall=100.0, index=3),
        record("bare", "r30", False, 50.0, stall=200.0, radius=30.0, index=4),
    ]
    by_design = summarize(recs)
    assert [r["design_name"] for r in by_design] == ["b30", "bare"]
    b30, bare = by_design
    assert (b30["n"], b30["successes"], b30["success_rate"]) == (3, 2, pytest.approx(2 / 3))
    assert (b30["success_ci_lo"], b30["success_ci_hi"]) == pytest.approx(wilson_interval(2, 3))
    assert b30["median_time_s"] == 20.0 and b30["median_peak_pressure_kpa"] == 40.0
    assert b30["median_max_contact_force_n"] == pytest.approx(2.0)
    assert b30["median_stall_position_mm"] == 300.0 and b30["n_stalled"] == 1
    assert bare["success_rate"] == 0.0 and bare["success_ci_lo"] == 0.0
    assert bare["median_stall_position_mm"] == 150.0 and bare["median_time_s"] == 40.0

    by_two = summarize(recs, by=("design_name", "scene.params.radius_mm"))
    assert [(r["design_name"], r["scene.params.radius_mm"], r["n"]) for r in by_two] == [
        ("b30", 25.0, 2), ("b30", 30.0, 1), ("bare", 25.0, 1), ("bare", 30.0, 1)]
    assert by_two[0]["median_stall_position_mm"] is None and by_two[0]["n_stalled"] == 0
    assert [r["group"] for r in summarize(recs, by="group")] == ["r25", "r30"]
    with pytest.raises(ValueError, match="by = 'scene.params.angle_deg' is not in trial"):
        summarize(recs, by="scene.params.angle_deg")
    assert summarize([]) == []


# ---------------------------------------------------------------- store


def test_store_adds_once_commits_and_filters(tmp_path):
    path = tmp_path / "scores.sqlite"
    specs = make_specs(4)
    with ResultStore(path) as store:
        assert store.add(specs[0], fake_trial(specs[0]), wall_s=0.5)
        first = store.results()[0]
        again = dict(fake_trial(specs[0]), success=not first.result["success"])
        assert not store.add(specs[0], again)  # INSERT OR IGNORE: the first result stays
        for spec in specs[1:]:
            store.add(spec, fake_trial(spec))
        with pytest.raises(TrialResultError):
            store.add(make_specs(5)[4], {"success": True})
        assert len(store) == 4
    assert [k for k, _ in rows(path)] == [s.key for s in specs]  # committed, visible to a new reader
    with ResultStore(path) as store:
        assert store.done_keys() == {s.key for s in specs}
        (rec,) = store.results(keys=[specs[0].key])
        assert rec.result == first.result and rec.spec == specs[0] and rec.wall_s == 0.5
        assert {"run_id", "command", "versions", "platform", "git"} <= set(rec.meta)
        assert rec.meta["versions"]["numpy"] == np.__version__
        assert [r.spec.index for r in store.results(design_name="b30")] == [1, 3]
        assert [r.spec.index for r in store.results(keys=[s.key for s in specs[::-1]], index=[0, 2])] == [0, 2]
        n_ok = sum(fake_trial(s)["success"] for s in specs)
        assert len(store.results(success=True)) == n_ok
        with pytest.raises(ValueError, match="unknown results filter 'radius': allowed design_name, group"):
            store.results(radius=1)
    with sqlite3.connect(path) as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"


# ---------------------------------------------------------------- runner


def test_serial_run_resumes_and_returns_records_in_spec_order(tmp_path, capsys):
    specs = make_specs(6)
    with ResultStore(tmp_path / "s.sqlite") as store:
        first = run_trials(specs[:3], fake_trial, store, backend="serial")
        assert "scoring (serial): 100%|" in capsys.readouterr().err
        # stored trials are not rerun: 0..2 keep their first results, only 3..5 run (3 fails)
        with pytest.warns(RuntimeWarning, match=r"1 of 6 trials failed(.|\n)*trial 3 \(design"):
            recs = run_trials(specs, failing_trial, store, backend="serial", progress=False, on_error="warn")
    assert [r.spec for r in recs] == specs[:3] + specs[4:]
    assert [r.result for r in recs[:3]] == [r.result for r in first]
    assert all(r.result == check_result(fake_trial(r.spec)) for r in recs)


def test_resuming_over_trials_of_another_build_warns_and_reuses_them(tmp_path):
    """A store keeps each trial's code fingerprint; reusing trials computed by another build
    of evertgym warns (the results are not silently current), reusing this build's does not."""
    import warnings

    from evertgym.scoring import StaleResultsWarning
    from evertgym.scoring.provenance import code_fingerprint, run_metadata

    specs = make_specs(3)
    with ResultStore(tmp_path / "s.sqlite") as store:
        run_trials(specs[:2], fake_trial, store, backend="serial", progress=False)
        assert set(store.fingerprints(s.key for s in specs[:2]).values()) == {code_fingerprint()}
        with warnings.catch_warnings():
            warnings.simplefilter("error", StaleResultsWarning)
            run_trials(specs[:2], fake_trial, store, backend="serial", progress=False)
        store.add(specs[2], fake_trial(specs[2]), meta={**run_metadata(), "code_fingerprint": "0123456789abcdef"})
        with pytest.warns(StaleResultsWarning, match="1 of the 3 stored trials"):
            recs = run_trials(specs, fake_trial, store, backend="serial", progress=False)
        assert store.fingerprints([specs[2].key]) == {specs[2].key: "0123456789abcdef"}  # reused, not rerun
    assert len(recs) == 3


def test_runner_rejects_bad_arguments(tmp_path):
    specs = make_specs(2)
    with ResultStore(tmp_path / "s.sqlite") as store:
        for kwargs, message in [
            (dict(backend="threads"), "backend = 'threads' is not allowed: allowed one of serial, process, dask"),
            (dict(workers=0), "workers = 0 is out of range: allowed an integer >= 1"),
            (dict(address="tcp://localhost:8786"), "address = 'tcp://localhost:8786' is not allowed with backend"),
            (dict(on_error="ignore"), "on_error = 'ignore' is not allowed"),
            (dict(backend="dask", address="tcp://localhost:8786", workers=2), "workers = 2 is not allowed with an"),
        ]:
            with pytest.raises(ValueError, match=message):
                run_trials(specs, fake_trial, store, progress=False, **kwargs)
        with pytest.raises(ValueError, match=r"specs\[2\] is the same trial as specs\[0\]"):
            run_trials(specs + specs[:1], fake_trial, store, backend="serial", progress=False)
        with pytest.raises(ValueError, match="cannot be sent to worker processes"):
            run_trials(specs, lambda spec: fake_trial(spec), store, backend="process", progress=False)
        assert len(store) == 0


def test_failed_trials_store_nothing_and_are_retried_on_resume(tmp_path):
    specs = make_specs(10)
    with ResultStore(tmp_path / "s.sqlite") as store:
        with pytest.raises(TrialsFailed) as err:
            run_trials(specs, failing_trial, store, backend="serial", progress=False)
        message = str(err.value)
        assert message.startswith("2 of 10 trials failed and stored nothing")
        assert "trial 3 (design 'b30', group 'r25', seed 1003" in message and "trial 7 (" in message
        assert "RuntimeError: simulated failure in trial 3" in message and "Traceback" in message
        assert [f.spec.index for f in err.value.failures] == [3, 7]
        assert len(store) == 8
        with pytest.raises(TrialsFailed, match=r"invalid result: the trial result lacks required keys \['success'\]"):
            run_trials(specs, invalid_trial, store, backend="serial", progress=False)
        assert len(store) == 9  # trial 7 now stored, trial 3 (invalid result) still missing
        with pytest.warns(RuntimeWarning, match="1 of 10 trials failed"):
            recs = run_trials(specs, failing_trial, store, backend="process", workers=2, progress=False,
                              on_error="warn")
        assert len(recs) == 9
        recs = run_trials(specs, fake_trial, store, backend="process", workers=2, progress=False)
    assert [r.spec for r in recs] == specs


def test_process_pool_survives_a_worker_crash(tmp_path):
    specs = make_specs(12, 0.02)
    with ResultStore(tmp_path / "s.sqlite") as store:
        with pytest.raises(TrialsFailed) as err:
            run_trials(specs, crashing_trial, store, backend="process", workers=2, progress=False)
        assert [f.spec.index for f in err.value.failures] == [5]
        assert "its worker process died while it ran alone" in str(err.value)
        assert store.done_keys() == {s.key for s in specs if s.index != 5}
        recs = run_trials(specs, fake_trial, store, backend="process", workers=2, progress=False)
    assert all(r.result == check_result(fake_trial(r.spec)) for r in recs) and len(recs) == 12


def test_closing_the_process_backend_early_ends_its_workers():
    """A runner that stops reading (an exception, Ctrl-C) leaves no worker behind, even with
    trials still running (the pool must end without waiting for them)."""
    import psutil

    from evertgym.scoring.backends import process_backend

    specs = make_specs(6, 0.0)[:1] + make_specs(6, 30.0)[1:]
    gen = process_backend(fake_trial, specs, workers=2)
    spec, outcome = next(gen)
    assert spec.index == 0 and outcome.error is None
    # the workers are the fork server's children (the fork server itself stays, as Python's does)
    servers = [c for c in psutil.Process().children() if "forkserver" in " ".join(c.cmdline())]
    workers = [w for server in servers for w in server.children()]
    assert len(workers) == 2
    t0 = time.monotonic()
    gen.close()
    assert time.monotonic() - t0 < 10  # did not wait for the 30 s trial in flight
    gone, alive = psutil.wait_procs(workers, timeout=5)
    assert not alive


def test_killed_process_run_resumes_to_the_clean_serial_result(tmp_path):
    specs = make_specs(40, 0.05)
    path = tmp_path / "killed.sqlite"
    code = (
        f"import sys; sys.path[:0] = {[str(ROOT), str(TESTS)]!r}\n"
        "from _fake_trial import fake_trial, make_specs\n"
        "from evertgym.scoring import ResultStore, run_trials\n"
        f"run_trials(make_specs(40, 0.05), fake_trial, ResultStore({str(path)!r}), backend='process', workers=2,"
        " progress=False)\n"
    )
    log = open(tmp_path / "child.log", "w")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=log, stderr=log, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        n = 0
        while n < 8 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
            try:
                n = len(rows(path))
            except sqlite3.OperationalError:  # not created yet
                pass
        os.kill(proc.pid, signal.SIGKILL)
        assert proc.wait(10) == -signal.SIGKILL, (tmp_path / "child.log").read_text()
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)  # the orphaned pool workers of the killed run
        except ProcessLookupError:
            pass
        log.close()
    killed = rows(path)
    assert 8 <= len(killed) < 40
    with sqlite3.connect(path) as db:
        assert db.execute("PRAGMA integrity_check").fetchone()[0] == "ok"

    with ResultStore(path) as store:
        resumed = run_trials(specs, fake_trial, store, backend="process", workers=2, progress=False)
    stored = rows(path)
    assert len(stored) == 40 and {k for k, _ in stored} == {s.key for s in specs}
    assert stored[: len(killed)] == killed  # nothing finished was lost or rewritten
    assert len({run for _, run in stored[len(killed):]}) == 1
    with ResultStore(tmp_path / "clean.sqlite") as store:
        clean = run_trials(specs, fake_trial, store, backend="serial", progress=False)
    assert [(r.key, r.result) for r in resumed] == [(r.key, r.result) for r in clean]


def test_dask_backend_matches_serial_and_resumes(tmp_path):
    from dask.distributed import LocalCluster

    specs = make_specs(12, 0.02)
    with ResultStore(tmp_path / "serial.sqlite") as store:
        serial = run_trials(specs, fake_trial, store, backend="serial", progress=False)
    path = tmp_path / "dask.sqlite"
    with ResultStore(path) as store:
        first = run_trials(specs[:5], fake_trial, store, backend="dask", workers=2, progress=False)
        assert len(first) == 5 and first[0].meta["backend"] == "dask" and first[0].meta["workers"] == 2
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            recs = run_trials(specs, fake_trial, store, backend="dask", address=cluster.scheduler_address,
                              progress=False)
            with ResultStore(tmp_path / "fail.sqlite") as fail_store:
                with pytest.raises(TrialsFailed) as err:
                    run_trials(make_specs(10), failing_trial, fail_store, backend="dask",
                               address=cluster.scheduler_address, progress=False)
                assert [f.spec.index for f in err.value.failures] == [3, 7] and len(fail_store) == 8
    assert [(r.key, r.result) for r in recs] == [(r.key, r.result) for r in serial]
    runs = [run for _, run in rows(path)]
    assert runs[:5] == [first[0].meta["run_id"]] * 5 and len(set(runs[5:])) == 1 and runs[5] != runs[0]
    assert recs[5].meta["address"] == cluster.scheduler_address and recs[5].meta["n_todo"] == 7
