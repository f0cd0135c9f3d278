"""The plan: every check before the first block, the one window, and `micropit scene` refusing
what `micropit run` would refuse (docs/architecture.md)."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest
from helpers import SCENES

from micropit_hpc.cli import main
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.errors import MicropitError, SceneError
from micropit_hpc.mechanics.halfspace import depth_layers
from micropit_hpc.plan import LEVELS, Window, make_plan, work_items
from micropit_hpc.scene import load_scene, scene_from_dict

DOC = {
    "study": {"name": "plan", "patches": 2},
    "disc": {"p0_GPa": 1.1, "u_mean_m_s": 1.1, "slide_roll": [0.1, 0.3],
             "radius1_x_mm": 6.0, "radius2_x_mm": 27.075},
    "body1": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.16,
              "surface": {"acf": "gaussian", "corr_x_um": 15.0, "corr_y_um": 40.0}},
    "body2": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.21,
              "surface": {"acf": "gaussian", "corr_x_um": 15.0, "corr_y_um": 40.0}},
    "lubricant": {"eta0_mPas": 3.1, "alpha_pv_1_per_GPa": 14.0, "eyring_stress_MPa": 5.0},
    "film": {"hc_um": 0.037},
    "window": {"n": 32, "steps": 4},
    "stress": {"layers": 5, "depth_b": 0.3, "spacing": "uniform"},
    "wear": {"k_lub_s": [0.0, 1e-11]},
    "life": {"cycles_M": 2.5, "block_M": 1.0},
}


def _doc(**changes):
    doc = copy.deepcopy(DOC)
    for dotted, value in changes.items():
        table, key = dotted.rsplit(".", 1)
        node = doc
        for part in table.split("."):
            node = node.setdefault(part, {})
        if value is None:
            node.pop(key, None)
        else:
            node[key] = value
    return doc


def test_the_plan_holds_conditions_window_items_levels_and_blocks():
    scene = scene_from_dict(_doc(), "plan.toml")
    plan = make_plan(scene)
    study = contact_study(scene)
    b = study.conditions[0].b
    assert plan.window.b_ref == b
    assert plan.window.grid.lx == 2 * b and plan.window.grid.ly == 2 * b
    assert plan.window.grid.shape == (32, 32)
    np.testing.assert_array_equal(plan.window.z, depth_layers(5, 0.3 * b, "uniform"))
    assert plan.window.z_max == 0.3 * b
    assert plan.items == tuple(work_items(scene, 2))
    assert len(plan.items) == 2 * 2 * 2                  # positions × k_lub × patches
    assert plan.levels == ("mixed", "mixed") and set(plan.levels) <= set(LEVELS)
    assert plan.blocks == 3 and plan.block_cycles(3) == 0.5e6
    assert plan.item_lambda(plan.items[0]) == study.conditions[0].Lambda
    assert plan.window_problems == ()


def test_the_queue_hands_out_the_wear_and_the_slip_first():
    """Plan.queue_order (the dynamic balance's order, docs/hpc.md §2): k_lub first, then the
    transit's slip 2b|S|, then the roughness scale, then the id; every item once."""
    scene = scene_from_dict(_doc(**{"disc.slide_roll": [0.0, 0.3, 0.1],
                                    "wear.k_lub_s": [0.0, 5e-11, 1e-11],
                                    "study.roughness_scale": [1.0, 2.0]}), "plan.toml")
    plan = make_plan(scene)
    order = plan.queue_order()
    assert sorted(order) == list(range(len(plan.items))) == [it.id for it in plan.items]

    def slip(it):
        c = plan.conditions(it.position)
        return 2.0 * c.b * abs(c.S)

    keys = [(-it.k_lub, -slip(it), -it.scale, it.id) for it in (plan.items[i] for i in order)]
    assert keys == sorted(keys)
    assert order != list(range(len(plan.items)))
    first, last = plan.items[order[0]], plan.items[order[-1]]
    assert (first.k_lub, first.position, first.scale, first.patch) == (5e-11, 2, 2.0, 0)
    assert (last.k_lub, last.position, last.scale, last.patch) == (0.0, 1, 1.0, 1)
    # the paper gear (2 patches): the items at 5e-11 s of the four positions with the most
    # slip (2, 3, 9, 10: 62–66 time steps) go out first; the two costliest of the measured
    # block 1 (docs/performance.md §3) are among them
    gear = make_plan(load_scene(SCENES / "paper_gear_z23.toml"))
    top = {(gear.items[i].position, gear.items[i].k_lub) for i in gear.queue_order()[:8]}
    assert top == {(p, 5e-11) for p in (2, 3, 9, 10)}


def test_the_window_is_read_only_and_is_the_cycles():
    scene = scene_from_dict(_doc(), "plan.toml")
    plan = make_plan(scene)
    with pytest.raises(ValueError):
        plan.window.z[0] = 1.0
    cycle = PositionCycle(plan.study, 2, window=plan.window)
    assert cycle.grid is plan.window.grid and cycle.z is plan.window.z
    own = PositionCycle(contact_study(scene), 2)        # without the plan: the same window
    assert own.grid == plan.window.grid
    np.testing.assert_array_equal(own.z, plan.window.z)
    assert Window.of(plan.study).b_ref == plan.window.b_ref


def test_a_missing_eyring_stress_is_refused_by_the_plan():
    doc = _doc(**{"lubricant.eyring_stress_MPa": None})
    scene = scene_from_dict(doc, "plan.toml")     # the file alone is valid
    with pytest.raises(SceneError, match="lubricant.eyring_stress_MPa"):
        make_plan(scene)
    # a dry contact needs no rheology
    make_plan(scene_from_dict(_doc(**{"lubricant.eyring_stress_MPa": None,
                                      "lubrication.model": "dry"}), "plan.toml"))


def test_a_surface_at_rest_is_refused_for_a_life_only():
    scene = scene_from_dict(_doc(**{"disc.slide_roll": [0.1, 2.0]}), "plan.toml")
    with pytest.raises(SceneError, match="never completes a load cycle"):
        make_plan(scene)
    assert make_plan(scene, life=False).blocks == 0
    assert len(make_plan(scene, positions=[1]).items) == 4     # position 2 not chosen


def test_position_options_are_checked():
    scene = scene_from_dict(_doc(), "plan.toml")
    with pytest.raises(MicropitError, match="position 3 does not exist"):
        make_plan(scene, positions=[3])
    with pytest.raises(MicropitError, match="more than once"):
        make_plan(scene, positions=[1, 1])


def _write(tmp_path, doc) -> str:
    lines = []

    def emit(prefix, table):
        scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
        if prefix:
            lines.append(f"[{prefix}]")
        for k, v in scalars.items():
            lines.append(f"{k} = {_toml(v)}")
        for k, v in table.items():
            if isinstance(v, dict):
                emit(f"{prefix}.{k}" if prefix else k, v)

    emit("", doc)
    path = tmp_path / "scene.toml"
    path.write_text("\n".join(lines) + "\n")
    assert tomllib.loads(path.read_text()) == doc
    return str(path)


def _toml(v) -> str:
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(v)


def test_micropit_scene_refuses_what_run_would(tmp_path, capsys):
    """`micropit scene` builds the plan: a missing Eyring stress and a surface file that does
    not exist are refused there, not at the first block of `micropit run`."""
    ok = _write(tmp_path, _doc())
    assert main(["scene", ok]) == 0
    out = capsys.readouterr().out
    assert "valid scene 'plan'" in out and "8 work items, 3 blocks" in out

    path = _write(tmp_path, _doc(**{"lubricant.eyring_stress_MPa": None}))
    assert main(["scene", path]) == 2
    assert "lubricant.eyring_stress_MPa" in capsys.readouterr().err

    path = _write(tmp_path, _doc(**{"body1.surface": {"kind": "file",
                                                      "file": "no_such_map.npy"}}))
    assert main(["scene", path]) == 2
    err = capsys.readouterr().err
    assert "body1.surface" in err and "no_such_map.npy" in err
