"""Robustness and security: bad input gets one line naming the field, model files
are code and load only when trusted, nothing is lost, resources are bounded."""

import json
import pickle
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from evertgym.agents.trust import SHIPPED_DIR, UntrustedModelError, model_files, trusted_hashes
from evertgym.cli import main
from evertgym.design import Band, DesignError, TubeDesign
from evertgym.env import EversionEnv
from evertgym.scenes import SceneSpec, make_scene

ROOT = Path(__file__).resolve().parents[1]
SHIPPED_ZIP = SHIPPED_DIR / "ubend_ppo_operator" / "final.zip"


# ---- model files are code -------------------------------------------------------------------
class _Payload:
    """Unpickling this writes a marker file: the stand-in for ``os.system``."""

    def __init__(self, marker: Path):
        self.marker = str(marker)

    def __reduce__(self):
        return (exec, (f"open({self.marker!r}, 'w').write('ran')",))


def _crafted_model(tmp_path: Path) -> tuple[Path, Path]:
    """A copy of a shipped model with a crafted ``_vecnormalize.pkl`` beside it."""
    folder = tmp_path / "copy"
    folder.mkdir()
    model = folder / "final.zip"
    shutil.copy(SHIPPED_ZIP, model)
    shutil.copy(SHIPPED_ZIP.with_name("final_env.json"), folder / "final_env.json")
    marker = tmp_path / "pwned"
    (folder / "final_vecnormalize.pkl").write_bytes(pickle.dumps(_Payload(marker)))
    return model, marker


def test_manifest_lists_every_shipped_model_file():
    """Regenerate with: python -m evertgym.agents.trust --write"""
    shipped = model_files(SHIPPED_DIR)
    assert shipped and set(shipped.values()) == trusted_hashes()


def test_a_crafted_pickle_beside_a_model_does_not_run_without_the_opt_in(tmp_path, capsys):
    from evertgym.agents.policies import make_policy

    model, marker = _crafted_model(tmp_path)
    with pytest.raises(UntrustedModelError, match="model files are code"):
        make_policy(str(model))
    assert main(["eval", str(model), "--env", "evertgym/UBend-v0", "--episodes", "1"]) == 2
    err = capsys.readouterr().err
    assert "--trust-model" in err and "final_vecnormalize.pkl" in err and "Traceback" not in err
    assert main(["score", "--policy", str(model), "--scenes", "1", "--trials", "1", "--db", str(tmp_path / "s.sqlite")]) == 2
    assert "--trust-model" in capsys.readouterr().err
    assert not marker.exists()
    # the opt-in is what lets it run: the payload is live
    with pytest.raises(Exception):  # noqa: B017 - the crafted object is no VecNormalize
        make_policy(str(model), trust=True)
    assert marker.read_text() == "ran"


def test_a_copy_of_a_shipped_policy_loads_without_the_opt_in(tmp_path):
    from evertgym.agents.policies import make_policy

    shutil.copytree(SHIPPED_ZIP.parent, tmp_path / "ubend_ppo_operator")
    assert make_policy(str(tmp_path / "ubend_ppo_operator" / "final.zip")).obs_rms is not None


# ---- validation at every boundary ------------------------------------------------------------
@pytest.mark.parametrize(
    "data, field",
    [
        ({"tube": {"length_mm": 10}}, "length_m"),  # Chipmunk aborted on it
        ({"tube": {"length_mm": 2**2000}}, "tube.length_mm"),  # beyond float range
        ({"tube": {"diameter_mm": True}}, "tube.diameter_mm"),
        ({"tube": {"diameter_mm": "40"}}, "tube.diameter_mm"),  # numeric text stays text: refused
        ({"bands": [{"position_mm": 300, "reduction": "0.3"}]}, "bands[0].reduction"),
        ({"bands": [{"position_mm": 300, "reduction": False}]}, "bands[0].reduction"),
        ({"bands": [{"position_mm": 300, "reduction": 1j}]}, "bands[0].reduction"),
        ({"bands": {"position_mm": 300}}, "bands"),
        ({"tube": [["length_mm", 600]]}, "tube"),
        ({"pressure_law": {"pressure_stiffening": None}}, "pressure_law.pressure_stiffening"),
        ([], "design file"),
    ],
)
def test_bad_design_fields_are_named(data, field):
    with pytest.raises(DesignError) as e:
        TubeDesign.from_dict(data)
    assert field in str(e.value) and "\n" not in str(e.value)


def test_design_numbers_are_stored_as_floats():
    d = TubeDesign.from_dict({"tube": {"length_mm": 600}, "bands": [{"position_mm": 300, "reduction": np.float32(0.25)}]})
    assert type(d.length_m) is float and type(d.bands[0].reduction) is float


def test_design_files_that_are_not_designs_name_the_file(tmp_path):
    (tmp_path / "bin.toml").write_bytes(b"\x00\xff\xfe")
    (tmp_path / "empty.toml").write_text("")
    for name in ("bin.toml", "empty.toml", "missing.toml"):
        with pytest.raises(DesignError, match=name):
            TubeDesign.load(tmp_path / name)


@pytest.mark.parametrize(
    "spec, field",
    [
        ({"family": ["ubend"]}, "family"),
        ({"family": {"a": 1}}, "family"),
        ({"family": "spiral"}, "family"),
        ({"family": "ubend", "params": [["radius_mm", 25]]}, "params"),
        ({"family": "ubend", "params": {"radius_mm": 10**400}}, "radius_mm"),
        ({"family": "ubend", "params": {"radius_mm": "25"}}, "radius_mm"),
        ({"family": "bend", "params": {"angle_deg": 1e-9, "lead_in_mm": 0, "lead_out_mm": 0, "goal_after_bend_mm": 0}},
         "lead_in_mm"),
        ({"family": "ubend", "seed": -1}, "seed"),
    ],
)
def test_bad_scene_specs_are_named(spec, field):
    from evertgym.scenes.spec import SceneError

    with pytest.raises(SceneError) as e:
        make_scene(spec)
    assert field in str(e.value)


def test_the_simulator_refuses_bodies_it_cannot_build_before_chipmunk_sees_them():
    from evertgym.sim import EversionSim, SimConfig

    with pytest.raises(ValueError, match="length_m"):
        EversionSim(TubeDesign(length_m=0.03), config=SimConfig(initial_length_m=0.04))
    with pytest.raises(ValueError, match="diameter_m"):
        EversionSim(TubeDesign(diameter_m=0.1), scene=make_scene(SceneSpec("ubend", {}, 0)))


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(design={"tube": {"length_mm": 600}, "bands": [{"position_mm": 20, "reduction": 0.1}]},
              band_offset_mm=(-25, 25)), "band_offset_mm"),
        (dict(band_offset_mm=(5, -5)), "band_offset_mm"),
        (dict(band_offset_mm="wide"), "band_offset_mm"),
        (dict(scene={"family": "spiral"}), "spiral"),
        (dict(scene={"family": "ubend", "params": {"radius_mm": {"uniform": [25, 90]}}}), "radius_mm"),
        (dict(scene={"family": "ubend", "colour": "red"}), "colour"),
        (dict(scene="ubend"), "scene"),
        (dict(scene={"family": "bend", "params": 0.0}), "params"),  # found by tests/test_fuzz.py
        (dict(design={"tube": {"diameter_mm": 100}}), "diameter_mm"),
        (dict(scene={"family": "ubend", "params": {"lumen_mm": 20}}), "diameter_mm"),
        (dict(control_hz=1000), "control_hz"),
        (dict(control_hz=3), "control_hz"),
        (dict(control_hz=10**400), "control_hz"),  # found by tests/test_fuzz.py
        (dict(control_hz=0.01), "longer than max_episode_s"),  # a 100 s step: found by the slow env-kwargs fuzz
        (dict(entry_offset_mm=(-1e6, 1e6)), "entry_offset_mm"),
        (dict(tip_sensing="no"), "tip_sensing"),
        (dict(scene_ahead=1), "scene_ahead"),
        (dict(history=True), "history"),
        (dict(stall_weight="1"), "stall_weight"),
        (dict(sim_config={"dt": 0.001}), "sim_config"),
        (dict(design={"tube": {"length_mm": 10}}), "length_m"),
    ],
)
def test_bad_env_kwargs_are_named_at_construction(kwargs, field):
    with pytest.raises(ValueError) as e:
        EversionEnv(**kwargs)
    assert field in str(e.value) and "\n" not in str(e.value)


@pytest.fixture(scope="module")
def reset_env():
    env = EversionEnv(scene={"family": "straight", "params": {}}, design={"tube": {"length_mm": 300}})
    env.reset(seed=0)
    return env


@pytest.mark.parametrize("action", ["0.5", np.array(["0.5"]), 1j, np.array([0.1 + 0j]), True, np.array([True]),
                                    [np.nan], [np.inf], [0.1, 0.2], None, {"a": 1}])
def test_bad_actions_are_refused(reset_env, action):
    with pytest.raises(ValueError, match="action"):
        reset_env.step(action)


def test_a_band_offset_the_body_holds_resets_for_every_seed():
    env = EversionEnv(design={"tube": {"length_mm": 600}, "bands": [{"position_mm": 40, "reduction": 0.1}]},
                      scene={"family": "straight", "params": {}}, band_offset_mm=(-25, 25))
    for seed in range(20):
        env.reset(seed=seed)


# ---- the command line ----------------------------------------------------------------------
def _cli_cases(tmp: Path) -> list[tuple[list[str], str]]:
    (tmp / "bin.toml").write_bytes(b"\x00\xff\xfe")
    (tmp / "empty.toml").write_text("")
    (tmp / "notadb.sqlite").write_text("hello")
    con = sqlite3.connect(tmp / "foreign.sqlite")
    con.execute("CREATE TABLE x (a)")
    con.commit()
    con.close()
    db = ["--db", str(tmp / "s.sqlite")]
    return [
        (["score", "--design", str(tmp)] + db, "--design"),
        (["score", "--design", str(tmp / "nope.toml")] + db, "--design"),
        (["score", "--design", str(tmp / "bin.toml")] + db, "bin.toml"),
        (["score", "--design", str(tmp / "empty.toml")] + db, "empty.toml"),
        (["score", "--db", str(tmp), "--scenes", "1"], "--db"),
        (["score", "--db", str(tmp / "notadb.sqlite"), "--scenes", "1", "--trials", "1", "--max-s", "0.1", "--backend", "serial"],
         "notadb.sqlite"),
        (["score", "--db", str(tmp / "foreign.sqlite"), "--scenes", "1", "--trials", "1", "--max-s", "0.1", "--backend", "serial"],
         "foreign.sqlite"),
        (["score", "--max-s", "-1"] + db, "--max-s"),
        (["score", "--max-s", "nan"] + db, "--max-s"),
        (["score", "--band-jitter-mm", "1000", "--bands-mm", "450"] + db, "band_offset_mm"),
        (["score", "--band-jitter-mm", "5000"] + db, "--band-jitter-mm"),
        (["score", "--policy", "constant:pressure_kpa=99"] + db, "pressure_kpa"),
        (["score", "--policy", "nonsense"] + db, "nonsense"),
        (["score", "--policy", "nope.zip"] + db, "nope.zip"),
        (["score", "--policy", "constant:speed=3"] + db, "speed"),
        (["score", "--length-mm", "10"] + db, "length_m"),
        (["score", "--diameter-mm", "100"] + db, "diameter_mm"),
        (["score", "--scene", "spiral"] + db, "spiral"),
        (["score", "--scene-params", '[["radius_mm", 25]]'] + db, "params"),
        (["score", "--scenes", "100000", "--trials", "10000"] + db, "--scenes x --trials"),
        (["score", "--scenes", "0"] + db, "--scenes"),
        (["score", "--workers", "1000"] + db, "--workers"),
        (["eval", "operator", "--env", "evertgym/Nope-v0"], "--env"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--episodes", "1000000000000"], "--episodes"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--workers", "1000"], "--workers"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--workers", "0"], "--workers"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", "{bad"], "--env-kwargs"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--db", "/proc/nope/e.sqlite"], "--db"),
        (["rollout", "operator", "--env", "evertgym/UBend-v0", "--out", str(tmp / "r.gif"), "--env-kwargs", "[]"], "--env-kwargs"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", "[1]"], "--env-kwargs"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", '{"nope": 1}'], "nope"),
        (["eval", "operator", "--env", "evertgym/UBend-v0", "--env-kwargs", '{"regulator_tau_s": [0.1, 99]}'], "regulator_tau_s"),
        (["rollout", "operator", "--env", "evertgym/UBend-v0", "--out", str(tmp / "r.gif"), "--seed", "-1"], "--seed"),
        (["rollout", "operator", "--env", "evertgym/UBend-v0", "--out", "/proc/nope/r.gif"], "--out"),
        (["rollout", "operator", "--env", "evertgym/UBend-v0", "--out", str(tmp / "r.mp4")], "--out"),
        (["stiffness", "--pressure-kpa", "0.001", "--no-sim"], "--pressure-kpa"),
        (["stiffness", "--pressure-kpa", "0", "--no-sim"], "--pressure-kpa"),
        (["stiffness", "--design", str(tmp)], "--design"),
        (["optimize", "--scenes", "0"], "--scenes"),
        (["optimize", "--trials", "-1"], "--trials"),
        (["reproduce", "ubend", "--workers", "1000", "--db", str(tmp / "u.sqlite")], "--workers"),
        (["train", str(tmp / "nope.toml"), "--out", str(tmp)], "nope.toml"),
        (["train", str(ROOT / "agents" / "ubend_ppo_operator.toml"), "--out", str(tmp), "--seed", "-1"], "seed = -1"),
    ]


def test_cli_bad_inputs_get_one_line_and_exit_2(tmp_path, capsys):
    for argv, field in _cli_cases(tmp_path):
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 2, (argv, err)
        assert err.startswith("evertgym: error: ") and err.count("\n") == 1, (argv, err)
        assert field in err, (argv, err)


def test_cli_refuses_abbreviated_flags(capsys):
    with pytest.raises(SystemExit) as e:
        main(["score", "--trial", "3"])
    assert e.value.code == 2 and "--trial" in capsys.readouterr().err


def test_cli_json_has_no_nan(capsys):
    assert main(["stiffness", "--displacement-mm", "0", "--no-sim", "--json"]) == 0
    out = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(f"bare {c} in JSON"))
    assert out["cosserat_n_per_m"] is None


def test_cli_quiet_on_a_closed_pipe():
    cmd = f"{sys.executable} -m evertgym.cli stiffness --no-sim --json | head -c 10"
    done = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, timeout=300)
    assert "Traceback" not in done.stderr and "BrokenPipe" not in done.stderr


def test_ctrl_c_says_the_same_command_resumes(tmp_path):
    cmd = [sys.executable, "-m", "evertgym.cli", "score", "--scenes", "1", "--trials", "50", "--backend", "serial",
           "--db", str(tmp_path / "s.sqlite"), "--max-s", "20"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not (tmp_path / "s.sqlite").exists():
        time.sleep(0.1)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and "rerun the same command to resume" in err


@pytest.mark.parametrize("address, local", [("tcp://127.0.0.1:8786", True), ("localhost:8786", True),
                                             ("tcp://[::1]:8786", True), ("inproc://x", True),
                                             ("tcp://10.0.0.5:8786", False), ("tls://example.org:8786", False)])
def test_dask_addresses_off_this_machine_are_not_local(address, local):
    from evertgym.cli_guard import is_local_address

    assert is_local_address(address) is local


# ---- nothing lost, nothing forged ------------------------------------------------------------
def test_an_edited_stored_result_is_reported_with_its_row(tmp_path):
    sys.path.insert(0, str(ROOT / "tests"))
    from _fake_trial import fake_trial, make_specs

    from evertgym.scoring.store import ResultStore

    specs = make_specs(3)
    with ResultStore(tmp_path / "s.sqlite") as store:
        for spec in specs:
            store.add(spec, fake_trial(spec))
        assert len(store.results()) == 3
    con = sqlite3.connect(tmp_path / "s.sqlite")
    con.execute("UPDATE trials SET result_json = replace(result_json, '\"success\":false', '\"success\":true') WHERE rowid = 2")
    con.execute("UPDATE trials SET result_json = replace(result_json, '\"success\":true', '\"success\":false') WHERE rowid = 2")
    con.execute("UPDATE trials SET result_json = replace(result_json, '\"time_s\":', '\"time_s\":1') WHERE rowid = 2")
    con.commit()
    con.close()
    with ResultStore(tmp_path / "s.sqlite") as store:
        with pytest.raises(ValueError, match="row 2 fails its checksum"):
            store.results()


@pytest.mark.parametrize("name", ["../../x", "/tmp/abs", "a/b", ".hidden", "", 3])
def test_a_training_run_name_cannot_leave_out(tmp_path, name):
    from evertgym.agents.train import load_config

    cfg = tmp_path / "c.toml"
    cfg.write_text(f'name = {json.dumps(name)}\nenv_id = "evertgym/UBend-v0"\nalgo = "ppo"\nn_timesteps = 10\n')
    with pytest.raises(ValueError, match="name"):
        load_config(cfg)


def test_resume_skips_torn_checkpoints(tmp_path):
    """Torn files (a crash mid-write) fall back to the newest checkpoint that loads."""
    import zipfile

    from evertgym.agents.train import _load_checkpoint

    for steps in (100, 200, 300):
        with zipfile.ZipFile(tmp_path / f"model_{steps}_steps.zip", "w") as z:
            z.writestr("data", str(steps))
        (tmp_path / f"model_vecnormalize_{steps}_steps.pkl").write_bytes(pickle.dumps({"steps": steps}))
    newest = tmp_path / "model_300_steps.zip"
    newest.write_bytes(newest.read_bytes()[:20])  # torn zip
    stats = tmp_path / "model_vecnormalize_200_steps.pkl"
    stats.write_bytes(stats.read_bytes()[:5])  # torn pkl

    def load(ckpt, pkl):
        with open(pkl, "rb") as f:
            return ckpt.name, pickle.load(f)["steps"]

    assert _load_checkpoint(tmp_path, True, load) == ("model_100_steps.zip", 100)
    (tmp_path / "model_vecnormalize_100_steps.pkl").write_bytes(b"")
    with pytest.raises(ValueError, match="no complete checkpoint"):
        _load_checkpoint(tmp_path, True, load)


def test_the_event_log_is_bounded(monkeypatch):
    import evertgym.sim.tube as tube  # both engines' event log
    from evertgym.sim import EversionSim

    monkeypatch.setattr(tube, "MAX_EVENTS", 5)
    sim = EversionSim(TubeDesign(length_m=0.3))
    for _ in range(12):
        sim._event("stall", pressure_kpa=1.0)
    assert len(sim.events) == 5 and sim.event_counts["stall"] == 12


# ---- limits ----------------------------------------------------------------------------------
def test_workers_are_capped_at_the_cpu_count_unless_forced():
    from evertgym.limits import check_workers, cpu_count

    assert check_workers(cpu_count()) == cpu_count()
    with pytest.raises(ValueError, match="CPU count"):
        check_workers(cpu_count() + 1)
    assert check_workers(cpu_count() + 1, force=True) == cpu_count() + 1
    with pytest.raises(ValueError, match="workers"):
        check_workers(True)


def test_vectorised_band_lookup_matches_the_per_band_sum():
    from evertgym.model.section import TubeSection

    rng = np.random.default_rng(3)
    for _ in range(50):
        pos = np.cumsum(rng.uniform(0.0151, 0.05, rng.integers(0, 12))) + 0.01
        bands = tuple(Band(float(p), float(rng.uniform(0, 0.59))) for p in pos)
        sec = TubeSection(TubeDesign(length_m=1.0, bands=bands), 3000.0)
        s = rng.uniform(0, 1.0, 400)
        rho, alpha = np.zeros_like(s), np.ones_like(s)
        for z in sec.zones:
            w = z.shape(s)
            rho, alpha = np.maximum(rho, z.reduction * w), np.minimum(alpha, 1 - (1 - z.alpha) * w)
        got = sec._reduction_and_alpha(s)
        assert np.array_equal(got[0], rho) and np.array_equal(got[1], alpha)


def test_a_thousand_bands_build():
    from evertgym.sim import EversionSim

    d = TubeDesign(length_m=20.0, bands=tuple(Band(0.05 + 0.019 * i, 0.1) for i in range(1000)))
    sim = EversionSim(d)
    assert len(sim._ref_section.zones) == 1000
    with pytest.raises(DesignError, match="at most 1000"):
        TubeDesign(length_m=20.0, bands=tuple(Band(0.01 + 0.0151 * i, 0.1) for i in range(1001)))


@pytest.mark.slow
@pytest.mark.timeout(3700)
def test_rss_stays_flat_over_ten_simulated_minutes_of_20_hz_cycling():
    done = subprocess.run([sys.executable, "-m", "evertgym.bench.robustness", "--minutes", "10", "--json"],
                          capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stderr
    log = json.loads(done.stdout)["event_log"]
    assert log["events_at_end"] <= log["max_events"]
    assert log["rss_mib_at_end"] - log["rss_mib_at_1_min"] < 8.0  # the unbounded log grew 15.6 MiB in 3 minutes


def test_ctrl_c_waits_while_python_code_runs_inside_a_c_call():
    """The CLI's SIGINT handler redelivers the interrupt 10 ms later while the running Python code is a pymunk
    callback or numba's unpickling inside the boxing of a compiled call's result (raised there, the call fails
    with a SystemError instead of a clean KeyboardInterrupt); anywhere else it raises at once."""
    import types

    import numba.core.serialize

    from evertgym.cli_guard import _inside_c_call

    def frame(filename, back=None):
        return types.SimpleNamespace(f_code=types.SimpleNamespace(co_filename=filename), f_back=back)

    assert _inside_c_call(frame(numba.core.serialize.__file__, frame(__file__)))
    assert _inside_c_call(frame(__file__, frame("/x/site-packages/pymunk/space.py")))
    assert not _inside_c_call(frame(__file__, frame("/x/site-packages/numba/core/dispatcher.py")))
    assert not _inside_c_call(sys._getframe())
