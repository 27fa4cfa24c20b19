"""Results that must not be wrong without a word: a study of one scene is not the answer for
another, a model runs on the engine it was trained on, an action outside the action space is
not clipped in silence, and the band-design objective states its tie-break."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from evertgym.cli import main


def _quick_trial(spec) -> dict:
    """A trial that runs no simulation: success drawn from the seed and the scene."""
    rng = np.random.default_rng([spec.seed or 0, int(spec.scene["params"].get("radius_mm", 0))])
    success = bool(rng.random() < 0.5)
    return {"success": success, "time_s": 5.0, "peak_pressure_kpa": 3.0, "max_contact_force_n": 0.5,
            "stall_position_mm": None if success else 100.0, "n_steps": 10}


# ---- a band-design study is kept per scene and settings ---------------------------------------
def test_optimize_starts_a_new_study_for_another_scene_and_says_so(tmp_path, monkeypatch, capsys):
    pytest.importorskip("optuna")
    import evertgym.experiments.optimize as optimize
    from evertgym.scoring.store import ResultStore

    monkeypatch.setattr(optimize, "run_trial", _quick_trial)
    kw = dict(study_path=tmp_path / "s.sqlite", store_path=tmp_path / "t.sqlite", n_trials=2, n_scenes=1, trials_per_scene=1,
              held_out_scenes=1, backend="serial")
    first = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, **kw)
    assert first["study"]["new"] and first["study"]["other_studies"] == []
    other = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 25.0}}, **kw)
    # a search for 25 mm: its own designs on 25 mm training scenes, not the 30 mm answer
    assert other["study"]["new"] and other["study"]["resumed_designs"] == 0 and other["trials"] == 2
    with ResultStore(tmp_path / "t.sqlite") as store:
        searched = {r.spec.scene["params"]["radius_mm"] for r in store.results() if r.spec.design_name.startswith("candidate")}
    assert searched == {25.0, 30.0}
    assert "radius_mm = 30.0" in optimize.study_text(other["study"])
    again = optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, **kw)  # resumes the 30 mm study
    assert not again["study"]["new"] and again["study"]["resumed_designs"] == 2 and again["best_params"] == first["best_params"]
    with pytest.raises(ValueError, match="budget_kpa"):
        optimize.optimize_bands({"family": "ubend", "params": {"radius_mm": 30.0}}, budget_kpa=9.0, **kw)


def test_optimize_prints_its_study_and_its_tie_break(tmp_path, monkeypatch, capsys):
    pytest.importorskip("optuna")
    import evertgym.experiments.optimize as optimize

    monkeypatch.setattr(optimize, "run_trial", _quick_trial)
    argv = ["optimize", "--trials", "2", "--scenes", "1", "--trials-per-scene", "1", "--held-out", "1", "--backend", "serial",
            "--study", str(tmp_path / "s.sqlite"), "--db", str(tmp_path / "t.sqlite")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "study: a new one in" in out
    assert "minus 0.001 per band" in out and "fewer bands is best" in out
    assert main([*argv, "--scene-params", '{"radius_mm": 25}']) == 0
    out = capsys.readouterr().out
    assert "study: a new one in" in out and "other study is kept" in out
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "0.001 per band" in out["objective"] and out["study"]["resumed_designs"] == 2


# ---- an action outside the action space --------------------------------------------------------
def test_an_action_outside_the_action_space_warns_once_per_env():
    import gymnasium as gym

    import evertgym  # noqa: F401 - registers the envs

    env = gym.make("evertgym/UBend-v0", max_episode_s=1.0)
    env.reset(seed=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.step(np.array([0.5], dtype=np.float32))  # inside: no warning
        assert not [w for w in caught if "action space" in str(w.message)]
        env.step(np.array([10.0], dtype=np.float32))  # 10 kPa meant, 8 kPa played
        env.step(np.array([-3.0], dtype=np.float32))
    found = [str(w.message) for w in caught if "action space" in str(w.message)]
    assert len(found) == 1, found
    assert "action = 10 is outside the action space [-1, 1] and is clipped to 1" in found[0] and "kPa" in found[0]
    assert env.unwrapped.command_pa == 0.0  # -3 clipped to -1: 0 kPa
    env.close()
    other = gym.make("evertgym/UBend-v0", max_episode_s=1.0)  # a new env warns again
    other.reset(seed=0)
    with pytest.warns(UserWarning, match="outside the action space"):
        other.step(np.array([1.5]))
    other.close()
