"""Nothing runs, nothing is written and nothing is silently wrong.

* trust to unpickle comes only from the person running the code (``--trust-model``, ``trust=True``),
  never from a policy spec, a trial spec, a model's env file or a store;
* a file that is not an evertgym result store of this version (another application's SQLite file, an
  optuna study, an older store, random bytes) is identified read-only and refused in one line, left
  byte for byte as it was with no journal or WAL file made; a locked store says so;
* every solver setting in range converges or is counted: the tolerance has a floor, a step has a work
  budget, and unconverged solves appear in ``info``, trial results, ``score`` and ``reproduce``;
* types are checked at the edge (counts, ``--sim``, ``scene_seed``, repeated values, optimize's scene),
  and ``step()`` after the end of an episode raises until ``reset()``.
"""

import hashlib
import json
import os
import pickle
import shutil
import sqlite3
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from evertgym.agents.trust import SHIPPED_DIR
from evertgym.cli import main
from evertgym.env import EversionEnv
from evertgym.scoring.spec import TrialSpec
from evertgym.sim.config import SimConfig

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = SHIPPED_DIR / "ubend_ppo_operator"


class _Payload:
    """Unpickling this writes a marker file: the stand-in for ``os.system``."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (exec, (f"open({self.marker!r}, 'w').write('ran')",))


@pytest.fixture
def crafted(tmp_path):
    """A shipped model's zip beside a crafted ``_vecnormalize.pkl`` (not in the manifest): loading it runs the payload."""
    folder = tmp_path / "copy"
    folder.mkdir()
    shutil.copy(SHIPPED / "final.zip", folder / "final.zip")
    shutil.copy(SHIPPED / "final_env.json", folder / "final_env.json")
    marker = tmp_path / "pwned"
    (folder / "final_vecnormalize.pkl").write_bytes(pickle.dumps(_Payload(marker)))
    return folder / "final.zip", marker


def _one_line_exit_2(argv, capsys, *needles):
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, (argv, err)
    assert err.startswith("evertgym: error: ") and err.count("\n") == 1 and "Traceback" not in err, (argv, err)
    for needle in needles:
        assert needle in err, (argv, needle, err)
    return err


# ---- trust only from the user ------------------------------------------------------------------
def test_a_trust_field_in_a_cli_policy_never_loads_a_model(crafted, tmp_path, capsys):
    model, marker = crafted
    spec = json.dumps({"name": "agent", "path": str(model), "trust": True})
    _one_line_exit_2(["score", "--policy", spec, "--scenes", "1", "--trials", "1", "--backend", "serial",
                      "--db", str(tmp_path / "s.sqlite")], capsys, "trust", "--trust-model")
    assert not marker.exists()
    assert not (tmp_path / "s.sqlite").exists()


def test_a_trust_field_in_a_python_policy_never_loads_a_model(crafted, tmp_path):
    from evertgym.agents.evaluate import episode_trial, evaluate
    from evertgym.agents.policies import make_policy
    from evertgym.agents.rollout import rollout_gif
    from evertgym.experiments.trial import run_trial

    model, marker = crafted
    desc = {"name": "agent", "path": str(model), "trust": True}
    with pytest.raises(ValueError, match="trust"):
        make_policy(desc)
    with pytest.raises(ValueError, match="trust"):
        make_policy({"name": "constant", "pressure_kpa": 3, "trust": True})
    with pytest.raises(ValueError, match="trust"):
        evaluate([desc], "evertgym/UBend-v0", 1)
    with pytest.raises(ValueError, match="trust"):
        rollout_gif(desc, "evertgym/UBend-v0", tmp_path / "r.gif")
    trial = TrialSpec(design={"tube": {"length_mm": 300.0}}, design_name="d",
                      scene={"family": "straight", "params": {"length_mm": 200.0}, "seed": 0}, policy=desc, seed=0, index=0, group="g")
    with pytest.raises(ValueError, match="trust"):
        run_trial(trial)
    episode = TrialSpec(design={}, design_name="e", scene={"family": "evertgym/UBend-v0", "params": {}, "seed": 1}, policy=desc,
                        seed=1, index=0, group="g")
    with pytest.raises(ValueError, match="trust"):
        episode_trial(episode)
    assert not marker.exists()


def test_a_models_env_file_cannot_name_a_model_to_load(crafted, tmp_path):
    """A shipped (trusted) model whose ``_env.json`` names, as its residual rule, the crafted model with trust."""
    from evertgym.agents.policies import make_policy

    model, marker = crafted
    folder = tmp_path / "shipped_copy"
    shutil.copytree(SHIPPED, folder)
    meta = json.loads((folder / "final_env.json").read_text())
    meta["residual"] = {"rule": {"name": "agent", "path": str(model), "trust": True}, "scale": 0.25}
    (folder / "final_env.json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="residual"):
        make_policy(str(folder / "final.zip"))
    assert not marker.exists()


def test_a_training_config_cannot_name_a_model_to_load(crafted, tmp_path):
    """A config's residual rule naming the crafted model with trust: refused when the config is read."""
    from evertgym.agents.train import load_config

    model, marker = crafted
    cfg = tmp_path / "c.toml"
    cfg.write_text('env_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 128\nzoo = false\n'
                   f'residual = {{ name = "agent", path = "{model}", trust = true }}\n')
    with pytest.raises(ValueError, match="residual"):
        load_config(cfg)
    assert not marker.exists()


def test_trust_model_with_a_zip_that_is_not_a_model_is_one_line(tmp_path, capsys):
    junk = tmp_path / "junk.zip"
    import zipfile

    with zipfile.ZipFile(junk, "w") as z:
        z.writestr("hello.txt", "not a model")
    (tmp_path / "random.zip").write_bytes(os.urandom(300))
    for path in (junk, tmp_path / "random.zip"):
        _one_line_exit_2(["score", "--policy", str(path), "--trust-model", "--scenes", "1", "--trials", "1", "--backend", "serial",
                          "--db", str(tmp_path / "s.sqlite")], capsys, "not a saved")
        _one_line_exit_2(["eval", str(path), "--trust-model", "--env", "evertgym/UBend-v0", "--episodes", "1"], capsys, path.name)


# ---- files that are not ours are never written ----------------------------------------------------
def _fingerprint(path: Path) -> tuple:
    """The file's bytes, mode and journal mode (header bytes 18-19), and which side files exist."""
    data = path.read_bytes()
    side = tuple(Path(str(path) + s).exists() for s in ("-wal", "-shm", "-journal"))
    return hashlib.sha256(data).hexdigest(), os.stat(path).st_mode, data[18:20], side


def _foreign(tmp: Path) -> Path:
    """Another application's SQLite file with a table named ``trials`` of another schema."""
    p = tmp / "foreign.sqlite"
    con = sqlite3.connect(p)
    con.execute("CREATE TABLE trials (id INTEGER PRIMARY KEY, name TEXT, score REAL)")
    con.execute("INSERT INTO trials (name, score) VALUES ('a', 1.0)")
    con.commit()
    con.close()
    return p


def _study(tmp: Path) -> Path:
    optuna = pytest.importorskip("optuna")
    p = tmp / "study.sqlite"
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(study_name="x", storage=f"sqlite:///{p}")
    study.optimize(lambda t: t.suggest_float("a", 0, 1), n_trials=2)
    del study
    import gc

    gc.collect()  # (optuna's engine keeps a connection until collected)
    return p


def _older(tmp: Path) -> Path:
    """An evertgym store of schema version 0 (before checksums), in WAL mode as stores were."""
    p = tmp / "older.sqlite"
    con = sqlite3.connect(p, isolation_level=None)
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("CREATE TABLE trials (key TEXT PRIMARY KEY, design_name TEXT NOT NULL, group_name TEXT NOT NULL, seed INTEGER NOT "
                "NULL, trial_index INTEGER NOT NULL, success INTEGER NOT NULL, spec_json TEXT NOT NULL, result_json TEXT NOT NULL, "
                "meta_json TEXT NOT NULL, wall_s REAL, finished_at TEXT NOT NULL)")
    con.close()
    return p


def _future(tmp: Path) -> Path:
    """A stamped evertgym store of a later schema version."""
    from evertgym.scoring.store import ResultStore

    p = tmp / "future.sqlite"
    ResultStore(p).close()
    con = sqlite3.connect(p)
    con.execute("PRAGMA user_version=2")
    con.commit()
    con.close()
    return p


def _commands(db: Path, tmp: Path) -> list[list[str]]:
    quick = ["--scenes", "1", "--trials", "1", "--max-s", "0.5", "--backend", "serial"]
    return [
        ["score", "--db", str(db), *quick],
        ["reproduce", "ubend", "--db", str(db), "--trials", "1", "--radii", "30", "--reductions", "0", "--backend", "serial"],
        ["reproduce", "colon", "--db", str(db)],
        ["eval", "operator", "--env", "evertgym/UBend-v0", "--episodes", "1", "--db", str(db)],
        ["optimize", "--db", str(db), "--study", str(tmp / "new_study.sqlite"), "--trials", "1", "--scenes", "1",
         "--trials-per-scene", "1", "--held-out", "1", "--backend", "serial"],
    ]


@pytest.mark.parametrize("make", [_foreign, _study, _older, _future], ids=["foreign", "optuna", "older", "future"])
def test_a_file_that_is_not_our_store_comes_back_byte_identical(make, tmp_path, capsys):
    db = make(tmp_path)
    before = _fingerprint(db)
    for argv in _commands(db, tmp_path):
        _one_line_exit_2(argv, capsys, str(db.name))
        assert _fingerprint(db) == before, argv
    assert not (tmp_path / "new_study.sqlite").exists()
    from evertgym.scoring.store import ResultStore

    with pytest.raises(ValueError, match="pass a new"):
        ResultStore(db)
    assert _fingerprint(db) == before


def test_study_files_are_identified_before_optuna_opens_them(tmp_path, capsys):
    study = _study(tmp_path)
    before = _fingerprint(study)
    quick = ["--trials", "1", "--scenes", "1", "--trials-per-scene", "1", "--held-out", "1", "--backend", "serial"]
    _one_line_exit_2(["optimize", "--study", str(study), "--db", str(study), *quick], capsys, "same file")
    assert _fingerprint(study) == before
    noise = tmp_path / "noise.sqlite"
    noise.write_bytes(os.urandom(4096))
    _one_line_exit_2(["optimize", "--study", str(noise), "--db", str(tmp_path / "d.sqlite"), *quick], capsys, "not an optuna study")
    for make in (_foreign, _older):
        other = make(tmp_path)
        fp = _fingerprint(other)
        _one_line_exit_2(["optimize", "--study", str(other), "--db", str(tmp_path / "d.sqlite"), *quick], capsys, "not an optuna study")
        assert _fingerprint(other) == fp
    assert not (tmp_path / "d.sqlite").exists()


def test_our_own_store_is_still_opened_and_an_unstamped_one_is_stamped(tmp_path):
    sys.path.insert(0, str(ROOT / "tests"))
    from _fake_trial import fake_trial, make_specs

    from evertgym.scoring.store import APPLICATION_ID, ResultStore, sqlite_header

    specs = make_specs(2)
    with ResultStore(tmp_path / "s.sqlite") as store:
        store.add(specs[0], fake_trial(specs[0]))
    assert sqlite_header(tmp_path / "s.sqlite") == (1, APPLICATION_ID)
    # a store written before the stamp (application_id 0): ours, stamped on its next open, nothing lost
    con = sqlite3.connect(tmp_path / "s.sqlite")
    con.execute("PRAGMA application_id=0")
    con.execute("UPDATE trials SET checksum = NULL")  # a row stored before checksums
    con.commit()
    con.close()
    with ResultStore(tmp_path / "s.sqlite") as store:
        store.add(specs[1], fake_trial(specs[1]))
        assert len(store.results()) == 2
    assert sqlite_header(tmp_path / "s.sqlite")[1] == APPLICATION_ID


def test_a_store_killed_before_its_first_checkpoint_is_still_ours(tmp_path):
    """A store written by a release before the stamp, its writer killed with the schema and rows still in
    the WAL file: identified from a copy (the originals untouched), then opened with every row."""
    import subprocess

    path = tmp_path / "killed.sqlite"
    script = (
        "import sqlite3, os\n"
        f"db = sqlite3.connect({str(path)!r}, isolation_level=None)\n"
        "db.execute('PRAGMA journal_mode=WAL')\n"
        "db.execute('PRAGMA wal_autocheckpoint=0')\n"
        "db.execute('CREATE TABLE trials (key TEXT PRIMARY KEY, design_name TEXT NOT NULL, group_name TEXT NOT NULL, seed INTEGER "
        "NOT NULL, trial_index INTEGER NOT NULL, success INTEGER NOT NULL, spec_json TEXT NOT NULL, result_json TEXT NOT NULL, "
        "meta_json TEXT NOT NULL, wall_s REAL, finished_at TEXT NOT NULL, checksum TEXT)')\n"
        "db.execute('PRAGMA user_version=1')\n"
        "os._exit(0)\n"  # no close: no checkpoint
    )
    subprocess.run([sys.executable, "-c", script], check=True)
    assert Path(str(path) + "-wal").stat().st_size > 0
    from evertgym.scoring.store import ResultStore, identify_store

    before = (path.read_bytes(), Path(str(path) + "-wal").read_bytes())
    assert identify_store(path) == "unstamped"
    assert (path.read_bytes(), Path(str(path) + "-wal").read_bytes()) == before
    with ResultStore(path) as store:
        assert len(store) == 0


def test_a_row_without_or_with_a_malformed_checksum_names_the_store_and_row(tmp_path):
    sys.path.insert(0, str(ROOT / "tests"))
    from _fake_trial import fake_trial, make_specs

    from evertgym.scoring.store import ResultStore

    specs = make_specs(3)
    path = tmp_path / "s.sqlite"
    with ResultStore(path) as store:
        for spec in specs:
            store.add(spec, fake_trial(spec))
    con = sqlite3.connect(path)
    con.execute("UPDATE trials SET checksum = NULL WHERE rowid = 2")
    con.commit()
    con.close()
    with ResultStore(path) as store, pytest.raises(ValueError, match=r"s\.sqlite: row 2 has no checksum"):
        store.results()
    con = sqlite3.connect(path)
    con.execute("UPDATE trials SET checksum = 'abc' WHERE rowid = 2")
    con.execute("UPDATE trials SET checksum = 17 WHERE rowid = 3")
    con.commit()
    con.close()
    with ResultStore(path) as store, pytest.raises(ValueError, match=r"s\.sqlite: row 2 fails its checksum"):
        store.results()
    # a malformed row whose checksum matches (written by hand): named, not a JSON traceback
    from evertgym.scoring.store import row_checksum

    con = sqlite3.connect(path)
    con.execute("UPDATE trials SET spec_json = '{bad', result_json = '{}', checksum = ? WHERE rowid = 2", (row_checksum("{bad", "{}"),))
    con.execute("DELETE FROM trials WHERE rowid = 3")
    con.commit()
    con.close()
    with ResultStore(path) as store, pytest.raises(ValueError, match=r"s\.sqlite: row 2 is malformed"):
        store.results()


def test_a_locked_store_says_it_is_locked_and_how_to_wait(tmp_path, capsys):
    from evertgym.scoring.store import ResultStore

    path = tmp_path / "s.sqlite"
    ResultStore(path).close()
    holder = sqlite3.connect(path, isolation_level=None)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        t0 = time.perf_counter()
        _one_line_exit_2(["score", "--db", str(path), "--wait", "0.3", "--scenes", "1", "--trials", "1", "--backend", "serial"],
                         capsys, "locked", "--wait")
        assert time.perf_counter() - t0 < 30
        with pytest.raises(ValueError, match="locked"):
            ResultStore(path, wait_s=0.1)
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    _one_line_exit_2(["score", "--db", str(path), "--wait", "-1"], capsys, "--wait")


# ---- every setting in range converges or is reported -------------------------------------------------
def test_a_tolerance_below_the_floor_is_refused_naming_it(capsys):
    from evertgym.sim.config import MIN_SOLVER_TOLERANCE

    with pytest.raises(ValueError, match=f"solver_tolerance = 1e-09 is out of range: allowed \\[{MIN_SOLVER_TOLERANCE:g}, 0.1\\]"):
        SimConfig(solver_tolerance=1e-9)
    SimConfig(solver_tolerance=MIN_SOLVER_TOLERANCE)
    _one_line_exit_2(["score", "--sim", '{"solver_tolerance": 1e-9}'], capsys, "solver_tolerance", "1e-05")
    _one_line_exit_2(["reproduce", "ubend", "--sim", '{"solver_tolerance": 1e-7}'], capsys, "solver_tolerance", "floor")


def _steps(env, n):
    obs, info = env.reset(seed=0)
    worst, total = 0.0, 0
    for _ in range(n):
        t0 = time.perf_counter()
        obs, _, term, trunc, info = env.step(np.zeros(1, np.float32))
        worst = max(worst, time.perf_counter() - t0)
        total += 1
        if term or trunc:
            break
    return worst, info


def test_the_step_budget_ends_solves_and_counts_them(monkeypatch):
    """With the budget made tiny, the hardest accepted tolerance and Newton budget: every step returns, and
    the solves the budget ended are counted as unconverged in ``info``."""
    from evertgym.sim import quasistatic

    monkeypatch.setattr(quasistatic, "_WORK_MIN", 200)
    monkeypatch.setattr(quasistatic, "_WORK_PER_S", 0)
    env = gym.make("evertgym/UBend-v0", sim_config={"solver_tolerance": 1e-5, "max_newton_iterations": 10000})
    worst, info = _steps(env, 40)
    assert info["solve_budget_cuts"] > 0 and info["solve_failures"] >= info["solve_budget_cuts"]
    assert info["unconverged_solves"] == info["solve_failures"]
    assert worst < 10.0


@pytest.mark.slow
@pytest.mark.timeout(1800)
@pytest.mark.parametrize("sim", [
    {"solver_tolerance": 1e-5, "max_newton_iterations": 10000},  # the hardest tolerance with the largest Newton budget
    {"growth_increment_m": 1e-6},  # 1,000x the solves
    {"segment_length_m": 0.0005, "growth_increment_m": 0.0005, "linear_solver": "dense"},  # O(m^3) Newton steps, m = 400
    {"engine": "dynamic", "dt_s": 1e-5, "iterations": 3},  # just below the dynamic engine's cap: the finest step ...
    {"engine": "dynamic", "dt_s": 1e-4, "iterations": 30, "segment_length_m": 0.001, "freeze_time_s": 1e6},  # ... 900 segments
], ids=["tolerance", "increment", "dense", "dynamic-dt", "dynamic-segments"])
def test_no_accepted_setting_makes_a_step_take_ten_seconds(sim):
    """The costliest accepted settings, through the U-bend at 4 kPa (scripts/robustness_numbers.py --worst-steps
    prints the same runs' numbers for docs/robustness.md)."""
    env = gym.make("evertgym/UBend-v0", sim_config=sim)
    worst, info = _steps(env, 80)
    assert worst < 10.0, (sim, worst, info)


def test_dynamic_settings_that_would_run_for_minutes_are_refused(capsys):
    with pytest.raises(ValueError, match="segment passes per simulated second: out of range"):
        EversionEnv(sim_config={"engine": "dynamic", "dt_s": 1e-5, "iterations": 1000})
    with pytest.raises(ValueError, match="segment passes"):
        EversionEnv(sim_config={"engine": "dynamic", "dt_s": 1e-5, "iterations": 27, "segment_length_m": 0.001})
    _one_line_exit_2(["score", "--sim", '{"engine": "dynamic", "dt_s": 1e-5, "iterations": 1000}'], capsys, "iterations = 1000")
    _one_line_exit_2(["reproduce", "ubend", "--sim", '{"engine": "dynamic", "dt_s": 1e-5, "iterations": 1000}'], capsys,
                     "iterations = 1000")


def test_relaxation_is_bounded_by_the_step_and_counted(monkeypatch):
    """The section law's relaxation never to rest (a speed no chain reaches) with the largest step cap: the
    step's work bound ends it, and each cut relaxation counts as an unconverged solve."""
    from evertgym.sim import tube

    sim = {"engine": "dynamic", "section_law": True, "max_relax_steps": 100000, "relax_speed_m_per_s": 1e-9}
    env = gym.make("evertgym/UBend-v0", sim_config=sim)
    env.reset(seed=0)
    # (the tip relaxes once it meets the bend's wall; a bound of about 2 relaxation steps per env step makes it quick)
    monkeypatch.setattr(tube, "_RELAX_WORK_MIN", 1e4)
    monkeypatch.setattr(tube, "MAX_DYNAMIC_WORK_PER_S", 1e5)
    for _ in range(60):
        _, _, _, _, info = env.step(np.zeros(1, np.float32))
        if env.unwrapped.sim.relax_steps:
            break
    assert info["unconverged_solves"] > 0 and env.unwrapped.sim.relax_budget_cuts == info["unconverged_solves"]
    assert env.unwrapped.sim.relax_steps < 10  # 100,000 per growth step without the bound


def test_unconverged_solves_are_in_env_info_on_both_engines():
    for engine in ("quasistatic", "dynamic"):
        env = gym.make("evertgym/UBend-v0", sim_config={"engine": engine})
        _, info = env.reset(seed=0)
        assert info["unconverged_solves"] == 0
        _, _, _, _, info = env.step(np.zeros(1, np.float32))
        assert isinstance(info["unconverged_solves"], int)


def test_score_and_reproduce_report_unconverged_solves(tmp_path, capsys, monkeypatch):
    """Trials run serially in this process, so the tiny budget applies: the counts reach every summary."""
    from evertgym.sim import quasistatic

    monkeypatch.setattr(quasistatic, "_WORK_MIN", 0)
    monkeypatch.setattr(quasistatic, "_WORK_PER_S", 0)
    argv = ["score", "--scenes", "1", "--trials", "1", "--max-s", "10", "--backend", "serial", "--scene-params", '{"radius_mm": 30}',
            "--db", str(tmp_path / "s.sqlite")]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["unconverged_solves"] > 0 and out["rows"][0]["unconverged_solves"] == out["unconverged_solves"]
    assert out["rows"][0]["trials_unconverged"] == 1
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "unconverged" in text and "warning: 1 trial(s)" in text
    ubend = ["reproduce", "ubend", "--trials", "1", "--radii", "30", "--reductions", "0", "--backend", "serial",
             "--db", str(tmp_path / "u.sqlite")]
    assert main([*ubend, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["unconverged_solves"] > 0 and out["rows"][0]["unconverged_solves"] == out["unconverged_solves"]
    assert main(ubend) == 0
    assert "unconverged" in capsys.readouterr().out


# ---- types at the edge --------------------------------------------------------------------------
@pytest.mark.parametrize("field", ["iterations", "law_interval", "max_relax_steps", "friction_lag_iterations", "max_newton_iterations"])
def test_integer_settings_refuse_non_integers(field):
    with pytest.raises(ValueError, match=f"{field} = 1.5 is out of range: allowed integers"):
        SimConfig(**{field: 1.5})
    with pytest.raises(ValueError, match=field):
        SimConfig(**{field: True})


def test_sim_must_be_a_json_object(capsys):
    for text in ("[]", '[["engine", "dynamic"]]', "3", "null", '"x"'):
        _one_line_exit_2(["score", "--sim", text], capsys, "--sim", "JSON object")
        _one_line_exit_2(["reproduce", "ubend", "--sim", text], capsys, "--sim")
    _one_line_exit_2(["score", "--sim", '{"max_newton_iterations": 1.5}'], capsys, "max_newton_iterations = 1.5")
    for bad in ([], [("engine", "dynamic")], "engine=dynamic", 3):
        with pytest.raises(ValueError, match="sim_config"):
            EversionEnv(sim_config=bad)


@pytest.mark.parametrize("seed", [1.7, True, "x", -1, np.float64(2.0), [1]])
def test_scene_seed_is_a_non_negative_integer(seed):
    env = EversionEnv()
    with pytest.raises(ValueError, match="scene_seed"):
        env.reset(seed=0, options={"scene_seed": seed})
    env.reset(seed=0, options={"scene_seed": np.int64(3)})


def test_repeated_radii_and_reductions_are_named_by_their_flag(capsys):
    _one_line_exit_2(["reproduce", "ubend", "--radii", "30,30"], capsys, "--radii", "more than once")
    _one_line_exit_2(["reproduce", "ubend", "--reductions", "0,0.1,0.1"], capsys, "--reductions", "more than once")


def test_optimize_checks_its_scene_and_settings_before_the_study(tmp_path, capsys):
    study, db = tmp_path / "study.sqlite", tmp_path / "db.sqlite"
    quick = ["--study", str(study), "--db", str(db), "--trials", "1", "--scenes", "1", "--trials-per-scene", "1", "--held-out", "1"]
    _one_line_exit_2(["optimize", "--scene-params", '{"radius_mm": 999}', *quick], capsys, "radius_mm")
    _one_line_exit_2(["optimize", "--scene-params", '{"nope": 1}', *quick], capsys, "nope")
    _one_line_exit_2(["optimize", "--scene", "spiral", *quick], capsys, "spiral")
    _one_line_exit_2(["optimize", "--sim", '{"solver_tolerance": 1e-9}', *quick], capsys, "solver_tolerance")
    _one_line_exit_2(["optimize", "--budget-kpa", "0", *quick], capsys, "--budget-kpa")
    _one_line_exit_2(["optimize", "--diameter-mm", "2", *quick], capsys, "--diameter-mm = 2.0", "[5, 500] mm")
    _one_line_exit_2(["optimize", "--length-mm", "nan", *quick], capsys, "--length-mm = nan", "[100, 20000] mm")
    _one_line_exit_2(["optimize", "--max-s", "0", *quick], capsys, "--max-s = 0.0", "[0.1, 3600] s")
    assert not study.exists() and not db.exists()


def test_step_after_the_end_of_an_episode_raises_until_reset():
    env = EversionEnv(scene={"family": "straight", "params": {"length_mm": 200.0}}, design={"tube": {"length_mm": 300.0}},
                      max_episode_s=0.3)
    env.reset(seed=0)
    ended = False
    for _ in range(10):
        _, _, term, trunc, _ = env.step(np.array([1.0], np.float32))
        if term or trunc:
            ended = True
            break
    assert ended
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.array([0.0], np.float32))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.array([0.0], np.float32))
    env.reset(seed=1)
    env.step(np.array([0.0], np.float32))


# ---- every CLI case: exit 2 and one line -----------------------------------------------------------
def test_issue_57s_cli_cases_end_in_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "noise.bin").write_bytes(os.urandom(2048))
    foreign = _foreign(tmp_path)
    store = tmp_path / "ok.sqlite"
    cases = [
        (["score", "--sim", "[]"], "--sim"),
        (["score", "--sim", '[["engine", "dynamic"]]'], "--sim"),
        (["score", "--sim", '{"max_newton_iterations": 1.5}'], "max_newton_iterations"),
        (["score", "--sim", '{"iterations": 2.5, "engine": "dynamic"}'], "iterations"),
        (["score", "--sim", '{"solver_tolerance": 1e-9}'], "solver_tolerance"),
        (["score", "--sim", '{"solver_tolerance": 1e-9, "max_newton_iterations": 10000}'], "solver_tolerance"),
        (["score", "--db", str(foreign)], "foreign.sqlite"),
        (["score", "--db", str(tmp_path / "noise.bin")], "noise.bin"),
        (["score", "--db", str(store), "--wait", "nan"], "--wait"),
        (["diagnose", "--sim", "[]"], "--sim"),
        (["diagnose", "--sim", '{"max_newton_iterations": 1.5}'], "max_newton_iterations"),
        (["reproduce", "ubend", "--radii", "30,30"], "--radii"),
        (["reproduce", "ubend", "--reductions", "0.1,0.1"], "--reductions"),
        (["reproduce", "ubend", "--db", str(foreign)], "foreign.sqlite"),
        (["reproduce", "colon", "--sim", "[1]"], "--sim"),
        (["reproduce", "colon", "--db", str(tmp_path / "noise.bin")], "noise.bin"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--db", str(foreign)], "foreign.sqlite"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", '{"sim_config": []}'], "sim_config"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", '{"sim_config": {"max_newton_iterations": 1.5}}'],
         "max_newton_iterations"),
        (["optimize", "--study", str(tmp_path / "noise.bin")], "noise.bin"),
        (["optimize", "--study", str(store), "--db", str(store)], "same file"),
        (["optimize", "--scene-params", '{"radius_mm": "x"}', "--study", str(tmp_path / "s1"), "--db", str(tmp_path / "d1")],
         "radius_mm"),
        (["optimize", "--sim", "[]"], "--sim"),
        (["rollout", str(tmp_path / "noise.bin"), "--env", "evertgym/UBend-v0", "--out", str(tmp_path / "r.gif")], "noise.bin"),
    ]
    for argv, needle in cases:
        _one_line_exit_2(argv, capsys, needle)
    assert not (tmp_path / "s1").exists() and not (tmp_path / "d1").exists()
