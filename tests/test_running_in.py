"""Plastic running-in of the asperity tips before the life (``life.running_in = "plastic"``,
micropit_hpc/running_in.py): each pass lowers each body by its hardness share of the largest
plastic overlap its columns met, the overlap falls pass by pass to the stop rule, and an item
runs it once, before its first block only."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import tiny_doc

import micropit_hpc.study as study_module
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.errors import SceneError
from micropit_hpc.life import contact_surfaces, initial_state
from micropit_hpc.plan import WorkItem
from micropit_hpc.running_in import hardness_shares, plastic_overlap, run_in
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.study import ItemRun


def _doc(model="dry", passes=60):
    """The tiny disc at |S| = 0.3 with soft bodies (p_lim = 1.8 GPa against p0 = 1.1 GPa: a
    contact that yields over half its area), body 2 twice as hard as body 1."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["body1"]["hardness_GPa"] = 3.0
    doc["body2"]["hardness_GPa"] = 6.0
    doc["lubrication"] = {"model": model}
    doc["life"].update(running_in="plastic", running_in_passes=passes, cycles_M=0.002,
                       block_M=0.001)
    return doc


def _cycle(doc):
    scene = scene_from_dict(doc, "t.toml")
    return scene, PositionCycle(contact_study(scene), 1)


def test_the_softer_body_takes_the_larger_share():
    assert hardness_shares(5e9, 5e9) == (0.5, 0.5)
    assert hardness_shares(3e9, 6e9) == pytest.approx((2 / 3, 1 / 3), rel=1e-15)


@pytest.mark.parametrize("model", ["dry", "auto"])
def test_one_pass_lowers_each_body_by_its_share_of_the_overlap_it_met(model):
    """One pass: the heights drop by exactly s_i × the body's overlap map (the largest
    negative clearance at p = p_lim over the steps, in the body's frame), nowhere rise, and
    drop only where a yielded point passed; the largest drop is at most s_i × the largest
    overlap of any step."""
    scene, cycle = _cycle(_doc(model, passes=1))
    state = initial_state(cycle)
    before = [b.heights.copy() for b in state.bodies]
    maps, worst, share = plastic_overlap(cycle, *contact_surfaces(state, cycle.grid,
                                                                  "unloaded"))
    assert worst > 0.0 and 0.2 < share < 1.0
    record = run_in(cycle, state, scene.life)
    assert record.passes == 1 and record.overlap_first == worst
    for b, h, m, s in zip(state.bodies, before, maps, (2 / 3, 1 / 3), strict=True):
        drop = h - b.heights
        # h − (h − s m) equals s m to the rounding of the subtraction
        assert np.allclose(drop, s * m, rtol=0.0, atol=4 * np.finfo(float).eps * np.abs(h).max())
        assert drop.min() >= 0.0 and np.all(drop[m == 0.0] == 0.0)
        assert drop.max() <= s * worst * (1 + 1e-12)
        assert 0.0 < drop.mean() < drop.max()


@pytest.mark.parametrize("model", ["dry", "auto"])
def test_the_overlap_falls_to_the_stop_rule(model):
    """Pass after pass the tips conform: the largest overlap falls by orders of magnitude, the
    yielded share of the contact falls, and the passes end at the stop rule (largest overlap
    ≤ running_in_overlap × composite R_q) well before the limit."""
    scene, cycle = _cycle(_doc(model, passes=200))
    state = initial_state(cycle)
    r = run_in(cycle, state, scene.life)
    stop = scene.life.running_in_overlap * math.hypot(*(b.rq0 for b in state.bodies))
    assert r.passes < 200 and r.overlap_last <= stop < 1e-3 * r.overlap_first
    assert r.plastic_last < r.plastic_first
    assert r.depth_mean[0] > r.depth_mean[1] > 0.0       # the softer body is flattened more
    for b in state.bodies:                               # the tips came down, R_q with them
        assert b.rq < b.rq0


def test_an_item_runs_in_once_before_its_first_block(monkeypatch):
    """ItemRun.run_block runs the running-in before the first block of a fresh state, logs
    one line, and not again; a state that has run blocks (a restart from a checkpoint, whose
    surfaces hold the running-in) is not run in."""
    calls = []
    real = study_module.run_in

    def counted(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(study_module, "run_in", counted)
    scene = scene_from_dict(_doc("dry", passes=5), "t.toml")
    said = []
    run = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0), log=said.append)
    fresh = [b.heights.copy() for b in run.state.bodies]
    run.run_block()
    run.run_block()
    assert len(calls) == 1 and run.running_in.passes == 5
    assert [s for s in said if "plastic running-in: 5 passes" in s]
    assert (fresh[0] - run.state.bodies[0].heights).min() >= 0.0
    restarted = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0))
    restarted.state.block = 1
    restarted.run_block()
    assert len(calls) == 1 and restarted.running_in is None


def test_the_running_in_reports_each_pass_as_sub_block_zero():
    """ItemRun.run_block's progress hook hears every pass of the running-in, as sub-block 0
    (step k of at most running_in_passes), before the first sub-block's steps; the progress
    line names it."""
    from micropit_hpc.progress import inside_note

    scene = scene_from_dict(_doc("dry", passes=4), "t.toml")
    run = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0))
    heard = []
    run.run_block(on_progress=lambda *a: heard.append(a))
    block = scene.life.block
    assert heard[:4] == [(0.0, block, 0, k, 4) for k in (1, 2, 3, 4)]
    assert heard[4][2] == 1 and all(h[2] >= 1 for h in heard[4:])
    note = inside_note(1, WorkItem(0, 1, 0.0, 1.0, 0), 0, 1, *heard[1])
    assert note.endswith("1 of 1 on this rank, plastic running-in, pass 2 of ≤ 4")


def test_a_running_in_that_is_not_offered_is_refused():
    doc = _doc()
    doc["life"]["running_in"] = "elastic"
    with pytest.raises(SceneError, match="running_in"):
        scene_from_dict(doc, "t.toml")
    doc["life"]["running_in"] = "none"
    scene, cycle = _cycle(doc)
    run = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0))
    fresh = run.state.bodies[0].heights.copy()
    run.run_block(1000)
    assert run.running_in is None
    assert np.array_equal(run.state.bodies[0].heights, fresh)
