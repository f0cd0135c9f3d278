"""The up-front memory and time estimate (issue 21 item 6): printed before every run; a run that
does not fit this node's memory is refused in one line, with the estimate, before anything is
written or allocated (the issue's cases: window.n = 8192, positions.n = 100000, a .npy header
claiming 200000²)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from helpers import error_lines, mpirun_fault, tiny_doc, write_scene

from micropit_hpc import estimate
from micropit_hpc.cli import main
from micropit_hpc.scene import scene_from_dict

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def run(tmp_path, doc, *extra):
    path = write_scene(tmp_path / "e.toml", doc)
    return main(["run", str(path), "--out", str(tmp_path / "out"), *extra])


@pytest.mark.slow
def test_the_estimate_is_printed_and_grows_with_the_window(tmp_path, capsys):
    rc = run(tmp_path, tiny_doc(slide_roll=(0.3,)))
    assert rc == 0
    err = capsys.readouterr().err
    line = next(ln for ln in err.splitlines() if ln.startswith("# estimate: "))
    assert "1 work items" in line and "GiB per rank" in line and "in all" in line
    small = scene_from_dict(tiny_doc(), "a.toml")
    doc = tiny_doc()
    doc["window"]["n"] = 1024
    big = scene_from_dict(doc, "b.toml")
    a = estimate.estimate(small, 1, 1, None, 2, 1)
    b = estimate.estimate(big, 1, 1, None, 2, 1)
    fixed = (estimate.PROCESS_MIB + estimate.CYCLE_MIB) * 2**20
    assert b.per_rank_bytes - fixed > 100 * (a.per_rank_bytes - fixed)
    assert b.total_s > 500 * a.total_s


def test_the_items_time_steps_are_those_their_runs_choose():
    """item_steps: each item's load cycle as its ItemRun raises it by the kinematics (here
    from window.steps = 8 to 12 and 68 at |S| = 0.05 and 0.3)."""
    from micropit_hpc.plan import make_plan
    from micropit_hpc.study import ItemRun

    doc = tiny_doc(slide_roll=(0.05, 0.3))
    doc["window"]["steps_per_peak_spacing"] = 24.0
    scene = scene_from_dict(doc, "t.toml")
    plan = make_plan(scene)
    steps = estimate.item_steps(plan)
    assert steps == tuple(ItemRun(scene, it, plan.study).cycle.steps for it in plan.items)
    assert len(set(steps)) == 2 and min(steps) > scene.window.steps


def test_the_estimate_follows_each_items_time_steps():
    """Memory from the most steps of any item, time from each item's steps, the items spread
    over the groups longest first."""
    scene = scene_from_dict(tiny_doc(slide_roll=(0.05, 0.3, 0.5)), "t.toml")
    m = scene.window.steps
    flat = estimate.estimate(scene, 2, 1, None, 2, 2)
    assert flat.steps == (m, m)
    raised = estimate.estimate(scene, 2, 1, None, 2, 2, (m, 2 * m, 4 * m))
    assert raised.steps == (m, 4 * m) and raised.per_rank_bytes > flat.per_rank_bytes
    one = flat.item_block_s
    assert raised.item_block_s == pytest.approx(one * 7 / 3, rel=1e-12)
    # 4m alone in one group, m + 2m in the other: the busiest group's 4 units per block
    assert raised.total_s == pytest.approx(2 * 4 * one, rel=1e-12)
    assert flat.total_s == pytest.approx(2 * 2 * one, rel=1e-12)
    assert f"({m}–{4 * m} time steps)" in raised.line() and f"({m} time steps)" in flat.line()
    with pytest.raises(ValueError, match="2 items' steps for 3 items"):
        estimate.estimate(scene, 2, 1, None, 2, 2, (m, m))


def test_the_busiest_group_takes_the_longest_items_first():
    assert estimate.busiest_group([2, 3, 2, 3, 2], 2) == 7       # 3+2+2 | 3+2
    assert estimate.busiest_group([5, 1, 1, 1], 2) == 5
    assert estimate.busiest_group([1.0] * 6, 3) == 2
    assert estimate.busiest_group([], 4) == 0


@pytest.mark.slow
def test_the_printed_estimate_names_the_raised_time_steps(tmp_path, capsys):
    doc = tiny_doc(slide_roll=(0.05,))
    doc["window"]["steps_per_peak_spacing"] = 24.0
    assert run(tmp_path, doc) == 0
    line = next(ln for ln in capsys.readouterr().err.splitlines()
                if ln.startswith("# estimate: "))
    assert "(12 time steps)" in line


@pytest.mark.slow
def test_a_window_of_8192_is_refused_with_the_estimate(tmp_path, capsys):
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 8192
    rc = run(tmp_path, doc)
    assert rc == 2
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("micropit: error:")]
    assert len(lines) == 1 and "window.n = 8192" in lines[0] and "GiB available" in lines[0]
    assert "Traceback" not in err and not (tmp_path / "out").exists()


@pytest.mark.slow
def test_100000_positions_are_refused(tmp_path, capsys):
    text = (ROOT / "scenes" / "quick.toml").read_text().replace("n = 5 ", "n = 100000 ")
    path = tmp_path / "many.toml"
    path.write_text(text)
    rc = main(["run", str(path), "--out", str(tmp_path / "out")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "100000 work items" in err and "--position" in err and "Traceback" not in err


@pytest.mark.slow
def test_a_npy_header_claiming_200000_squared_is_refused(tmp_path, capsys):
    with open(tmp_path / "huge.npy", "wb") as fh:
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<f8", "fortran_order": False, "shape": (200000, 200000)})
        fh.write(b"\0" * 64)
    doc = tiny_doc(slide_roll=(0.3,))
    doc["body1"]["surface"] = {"kind": "file", "file": "huge.npy", "spacing_um": [1.0, 1.0]}
    rc = run(tmp_path, doc)
    assert rc == 2
    err = capsys.readouterr().err
    assert 'body1.surface.file = "' in err and "200000 × 200000" in err
    assert "Traceback" not in err


@pytest.mark.slow
def test_ignore_memory_estimate_runs_anyway(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(estimate, "available_memory", lambda: 1.0)   # a node with 1 byte
    rc = run(tmp_path, tiny_doc(slide_roll=(0.3,)))
    assert rc == 2 and "more than the" in capsys.readouterr().err
    rc = run(tmp_path, tiny_doc(slide_roll=(0.3,)), "--ignore-memory-estimate")
    assert rc == 0


@pytest.mark.slow
@pytest.mark.timeout(120)
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_under_mpirun_the_refusal_is_printed_once(tmp_path):
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 8192
    path = write_scene(tmp_path / "e.toml", doc)
    rc, err = mpirun_fault(["run", path, "--out", tmp_path / "out"])
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "window.n = 8192" in lines[0], err
    assert "MPI_ABORT" not in err
