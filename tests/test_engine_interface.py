"""One engine interface: ``EversionSim`` is the base of both engines and builds the one the config names; what
both engines share is written once in it; the quasi-static engine builds nothing it never steps."""

from __future__ import annotations

import pytest

from evertgym.design import TubeDesign
from evertgym.scenes import make_scene
from evertgym.sim import DynamicSim, EversionSim, SimConfig
from evertgym.sim.quasistatic import QuasiStaticSim


@pytest.mark.parametrize("config, cls", [(None, QuasiStaticSim), (SimConfig(), QuasiStaticSim),
                                         (SimConfig(engine="dynamic"), DynamicSim)])
def test_eversion_sim_builds_the_engine_the_config_names_and_is_one(config, cls):
    sim = EversionSim(TubeDesign(length_m=0.2), config=config)
    assert type(sim) is cls and isinstance(sim, EversionSim) and sim.engine == sim.cfg.engine
    assert type(EversionSim(TubeDesign(length_m=0.2), None, config)) is cls  # positional config too


def test_an_engine_class_takes_only_its_own_engine_and_defaults_to_it():
    assert DynamicSim(TubeDesign(length_m=0.2)).cfg == SimConfig(engine="dynamic")
    assert QuasiStaticSim(TubeDesign(length_m=0.2)).cfg == SimConfig()
    with pytest.raises(ValueError, match=r"^engine = 'quasistatic' is out of range for DynamicSim: allowed 'dynamic'") as e:
        DynamicSim(TubeDesign(length_m=0.2), config=SimConfig())
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match=r"^engine = 'dynamic' is out of range for QuasiStaticSim"):
        QuasiStaticSim(TubeDesign(length_m=0.2), config=SimConfig(engine="dynamic"))


def test_the_base_declares_what_each_engine_computes():
    for name in ("step", "centreline", "radii", "tip_position", "tip_angle", "joint_angles", "joint_moments", "collapse_moments",
                 "segments_in_contact", "required_pressure", "solve_stats", "at_rest", "wall_tension", "compression_capacity",
                 "tip_capacity"):
        assert name in EversionSim.INTERFACE, name
        for engine in (DynamicSim, QuasiStaticSim):
            assert getattr(engine, name) is not getattr(EversionSim, name), (engine, name)
    with pytest.raises(TypeError, match="HalfEngine is not an engine: it must set engine and define _build_scene, _build_body, step"):
        type("HalfEngine", (EversionSim,), {"engine": "half"})
    for name in ("_event", "_stall_update", "_kink_events", "_band_events", "_contact_update", "_tail_weight", "_init_state",
                 "kinked_joints", "tip_direction"):  # written once, in the base
        assert name not in vars(DynamicSim) and name not in vars(QuasiStaticSim), name


def test_the_quasistatic_engine_builds_nothing_it_never_steps():
    scene = make_scene({"family": "colon"})  # compliant walls: pieces, springs and tethers on the dynamic engine
    design = TubeDesign(length_m=0.3, diameter_m=0.02)
    qs = EversionSim(design, scene=scene)
    assert not qs.space.constraints and not qs.scene_handles.springs  # no chain, no wall springs, no tethers
    assert qs.scene_handles.bodies and len(qs.space.bodies) == len(qs.scene_handles.bodies)  # the pieces show its solves
    assert not hasattr(qs, "bodies") and not hasattr(qs, "springs")
    dyn = EversionSim(design, scene=scene, config=SimConfig(engine="dynamic"))
    assert len(dyn.scene_handles.springs) and len(dyn.space.constraints) > len(dyn.scene_handles.springs)


def test_no_function_of_the_engines_takes_more_than_12_parameters_or_runs_past_100_lines():
    """A newcomer reads an engine function whole: none in ``evertgym/sim/`` has more than 12 parameters
    (``self`` not counted) or more than 100 lines."""
    import ast
    from pathlib import Path

    import evertgym.sim

    root = Path(evertgym.sim.__file__).parent
    offenders = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                params = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs if p.arg not in ("self", "cls")]
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if len(params) > 12 or lines > 100:
                    offenders.append(f"{path.relative_to(root)}:{node.name} ({len(params)} parameters, {lines} lines)")
    assert offenders == []
