"""micropit run: work items, summary.csv, results.h5; same numbers on 1 and 2 ranks."""

import csv
import math
import re
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import tiny_doc, write_scene

import micropit_hpc.study as study_mod
from micropit_hpc.cli import main
from micropit_hpc.parallel import SerialComm
from micropit_hpc.plan import work_items
from micropit_hpc.regime import item_list
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.study import SUMMARY_COLUMNS, Study

ROOT = Path(__file__).resolve().parents[1]


def test_work_item_ids_are_stable():
    doc = tiny_doc(k_lub=(0.0, 1e-11))
    doc["study"]["roughness_scale"] = [1.0, 0.5]
    scene = scene_from_dict(doc, "x.toml")
    items = work_items(scene, 2)
    assert [(i.id, i.position, i.k_lub, i.scale) for i in items[:5]] == [
        (0, 1, 0.0, 1.0, ), (1, 1, 0.0, 0.5), (2, 1, 1e-11, 1.0), (3, 1, 1e-11, 0.5),
        (4, 2, 0.0, 1.0)]


@pytest.mark.slow
def test_run_writes_summary_and_results(tmp_path, capsys):
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(0.0, 1e-11))
    doc["study"]["roughness_scale"] = [1.0, 0.5]
    scene = write_scene(tmp_path / "tiny.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 0
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    assert tuple(rows[0].keys()) == SUMMARY_COLUMNS
    assert len(rows) == 4 * 2 * 2                 # items × bodies × blocks
    lam = {r["item"]: float(r["Lambda"]) for r in rows}
    assert lam["1"] == pytest.approx(2 * lam["0"], rel=1e-5)      # roughness × 0.5 ⇒ Λ × 2
    for r in rows:
        assert 0.0 <= float(r["Ap_pct"]) <= 100.0
        assert 0.0 <= float(r["max_damage"]) < 1.0
        assert 0.0 <= float(r["phi"]) <= 1.0 and 0.0 <= float(r["pit_load_pct"]) <= 100.0
        assert int(r["sub_blocks"]) >= 1
        assert int(r["wear_cycles"]) == 0       # the relaxed wear of tiny_doc: none spent
    with h5py.File(tmp_path / "out" / "results.h5", "r") as f:
        assert f.attrs["complete"] == 1
        if (ROOT / ".git").exists():            # the code that made the numbers, traceable
            assert re.fullmatch(r"[0-9a-f]{7,}(-dirty)?", f.attrs["source_commit"])
        lam_h5 = f["items/Lambda"][()]
        assert lam_h5[1] == pytest.approx(2 * lam_h5[0], rel=1e-12)
        # λ_GF = h_c / ½(R_a1 + R_a2) of the item's own surfaces, so × 0.5 roughness ⇒ × 2;
        # for these Gaussian surfaces (R_q 0.16 and 0.21 µm) R_a ≈ √(2/π) R_q
        gf, hc = f["items/lambda_GF"][()], f["items/hc"][()]
        assert gf[1] == pytest.approx(2 * gf[0], rel=1e-12)
        for r in rows:       # summary.csv: the item's λ_GF; S_λ needs the oil's rating
            assert float(r["lambda_GF"]) == pytest.approx(gf[int(r["item"])], rel=1e-5)
            assert math.isnan(float(r["S_lambda"]))
        ra = math.sqrt(2 / math.pi) * 0.5 * (0.16e-6 + 0.21e-6)
        assert gf[0] == pytest.approx(hc[0] / ra, rel=0.1)
        assert hc[0] > 0 and f["items/single_pair"][0] == 1
        ap = f["history/item_00002/Ap"][-1]
        pitted = f["maps/item_00002/body1/pitted"][()]
        assert ap[0] == pytest.approx(100 * pitted.mean())
        damage = f["maps/item_00002/body1/damage"][()]
        assert damage.shape == (6, 32, 32)
        # the damage-risk map (Fig. 6): the largest damage over depth of each column
        np.testing.assert_array_equal(f["maps/item_00002/body1/damage_risk"][()],
                                      damage.max(axis=0))
        # the split is floored at ΔN/4 here: the log names each item whose pit step (share of
        # the window per sub-block) or wear step (shape change over R_q) exceeded its limit,
        # and only those
        over = {name: {i for i in range(4)
                       if f[f"history/item_{i:05d}/{name}"][()].max() > limit}
                for name, limit in (("pit_step", 0.01), ("wear_step", 0.1))}
    err = capsys.readouterr().err
    for name, what in (("pit_step", "newly pitted"), ("wear_step", "wear changed")):
        warned = {int(i) for m in re.findall(rf"warning: block \d+, items? ([\d, ]+): one "
                                             rf"sub-block(?:'s)? {what}", err)
                  for i in m.split(",")}
        assert warned == over[name], name
    assert over["pit_step"] and over["wear_step"]
    assert not list((tmp_path / "out").glob("*.tmp"))


def test_a_warning_names_few_items_and_counts_many():
    assert item_list([3]) == "item 3"
    assert item_list([0, 4]) == "items 0, 4"
    assert item_list(list(range(20)), show=3) == "items 0, 1, 2, … and 17 more (20 items)"


@pytest.mark.slow
def test_bad_position_is_a_clear_error(tmp_path, capsys):
    scene = write_scene(tmp_path / "tiny.toml", tiny_doc())
    assert main(["run", str(scene), "--out", str(tmp_path / "o"), "--position", "7"]) == 2
    assert "position 7 does not exist" in capsys.readouterr().err


@pytest.mark.mpi(min_size=2)
def test_one_and_two_ranks_give_bitwise_equal_records(tmp_path_factory):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    scene = scene_from_dict(tiny_doc(slide_roll=(0.15, 0.3), k_lub=(0.0,)), "tiny.toml")
    par = Study(scene, comm)
    par.setup()
    recs_par = [par.run_block(k) for k in (1, 2)]
    maps_par = par.gather_maps()
    ok = True
    if comm.rank == 0:
        ser = Study(scene, SerialComm())
        ser.setup()
        recs_ser = [ser.run_block(k) for k in (1, 2)]
        maps_ser = ser.gather_maps()
        def strip(recs):                 # everything but the wall time
            return [{i: replace(r, wall_s=0.0) for i, r in b.items()} for b in recs]

        ok = strip(recs_par) == strip(recs_ser) and all(
            np.array_equal(maps_par[i][k], maps_ser[i][k]) for i in maps_ser
            for k in maps_ser[i])
        ok = ok and par.group.count == comm.size and len(par.mine) <= 1
    assert all(comm.allgather(ok))


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_items_moved_between_groups_keep_their_numbers_bit_for_bit():
    """The dynamic balance (docs/hpc.md §2): block 1's items from the queue, block 2 after
    every item has moved to another group (:meth:`Study.reassign`, forced: the items swapped
    between the groups), blocks 3 and 4 from the queue with the states shared, block 5 moved
    longest-first (the share refused), equal one rank's run bit for bit, records and final
    maps."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    doc = tiny_doc(slide_roll=(0.15, 0.3), k_lub=(0.0, 1e-10))
    doc["life"]["cycles_M"] = 5.0
    scene = scene_from_dict(doc, "tiny.toml")
    par = Study(scene, comm)
    par.setup()
    ok = par.queued and not par.runs
    placed = {}                         # (block, place in the queue) → the item handed out

    def record(k, item, i, n, *rest):
        if rest[-1]:                    # queued
            placed[k, i] = item.id

    recs_par = [par.run_block(1, record)]
    before = [list(g) for g in par.assignment]
    ok = ok and sorted(i for g in before for i in g) == [0, 1, 2, 3] and not par.queued
    ok = ok and sorted(par.runs) == before[par.group.index]
    swapped = [before[(g + 1) % len(before)] for g in range(len(before))]
    par.reassign(swapped)
    ok = ok and sorted(par.runs) == swapped[par.group.index]
    par.costs = None                    # block 2 as swapped; block 3 from the queue again
    recs_par += [par.run_block(k, record) for k in (2, 3)]
    # block 4 again from the queue, with the items' states shared over the groups, and block 5
    # moved (the share too large)
    recs_par.append(par.run_block(4, record))
    # the queue handed out every item of blocks 1, 3 and 4 in the plan's order (the likely
    # costliest first, not item order), and none of block 2's
    everywhere = {}
    for part in comm.allgather(placed):
        everywhere.update(part)
    order = par.plan.queue_order()
    ok = ok and order != sorted(order) and everywhere == {
        (k, i): order[i] for k in (1, 3, 4) for i in range(len(order))}
    ok = ok and sorted(i for g in par.assignment for i in g) == [0, 1, 2, 3]
    ok = ok and sorted(par.runs) == par.assignment[par.group.index]
    study_mod.SHARE_BYTES, kept = 0, study_mod.SHARE_BYTES
    try:
        recs_par.append(par.run_block(5))
    finally:
        study_mod.SHARE_BYTES = kept
    maps_par = par.gather_maps()
    if comm.rank == 0:
        ser = Study(scene, SerialComm())
        ser.setup()
        recs_ser = [ser.run_block(k) for k in (1, 2, 3, 4, 5)]
        maps_ser = ser.gather_maps()

        def strip(recs):                 # everything but the wall time
            return [{i: replace(r, wall_s=0.0) for i, r in b.items()} for b in recs]

        ok = ok and strip(recs_par) == strip(recs_ser) and sorted(maps_par) == [0, 1, 2, 3]
        ok = ok and all(np.array_equal(maps_par[i][k], maps_ser[i][k]) for i in maps_ser
                        for k in maps_ser[i])
    assert all(comm.allgather(ok))


def coarse_quick_scene(path, positions: str):
    """scenes/quick.toml with the positions line ``positions`` (replacing ``n = 5``), a 16²
    window, 4 steps, 4 layers and one block: a few seconds of the real pipeline."""
    text = (ROOT / "scenes" / "quick.toml").read_text()
    for old, new in (("n = 5 ", positions), ("n = 64", "n = 16"), ("steps = 10", "steps = 4"),
                     ("layers = 8", "layers = 4"), ("cycles_M = 3.0", "cycles_M = 1.0")):
        assert old in text
        text = text.replace(old, new)
    path.write_text(text)
    return path


@pytest.mark.slow
def test_quick_scene_runs_and_the_flank_plot_reads_it(tmp_path):
    """scenes/quick.toml (coarsened) through `micropit run`, postprocess/plot_flank.py and
    postprocess/plot_life.py."""
    import subprocess
    import sys

    scene = coarse_quick_scene(tmp_path / "quick.toml", "n = 3 ")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == 0
    run = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_flank.py"), str(out)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    rows = list(csv.DictReader(open(out / "flank.csv")))
    assert [int(r["position"]) for r in rows] == [1, 2, 3]
    angles = [float(r["roll_angle_deg"]) for r in rows]
    assert angles == sorted(angles)
    pitch = rows[1]                                   # the middle of A-E: the pitch point
    assert abs(float(pitch["S"])) < 1e-9
    assert float(pitch["Ap1_pct"]) == 0.0 and float(pitch["Ap2_pct"]) == 0.0
    for r in rows:     # Method B beside A_p: no oil rating in quick.toml, so no λ_GFP
        assert float(r["lambda_GF"]) > 0 and math.isnan(float(r["lambda_GFP"]))
        assert math.isnan(float(r["S_lambda"]))
    assert (out / "flank.png").stat().st_size > 10_000
    run = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_life.py"), str(out)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert (out / "life.png").stat().st_size > 10_000     # A_p against cycles, damage maps


@pytest.mark.slow
@pytest.mark.parametrize("S", [2.0, -2.0])
def test_pure_sliding_is_a_clear_error_for_the_life_run(tmp_path, capsys, S):
    """|S| = 2 leaves one surface at rest: it never completes a load cycle (it used to end in
    a ZeroDivisionError in the micro-cycle count)."""
    scene = write_scene(tmp_path / "slide.toml", tiny_doc(slide_roll=(S,)))
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "slide.toml: disc.slide_roll = " in err and "|S| < 2" in err


@pytest.mark.slow
def test_positions_at_the_ends_of_the_path_of_contact_run(tmp_path):
    """Near-zero load at the very start and end of the path (p0 of a few MPa, with linear load
    sharing): the life run finishes with finite numbers, A_p in [0, 100], no damage < 0."""
    # A and E of this pair are at roll angles 17.61235 and 37.93559 deg (micropit contact)
    scene = coarse_quick_scene(tmp_path / "ends.toml", "roll_angle_deg = [17.6124, 37.9355] ")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == 0
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert len(rows) == 2 * 2
    for r in rows:
        assert float(r["p0_GPa"]) < 0.01
        for k in ("Ap_pct", "max_damage", "wear_um", "Rq_um"):
            assert np.isfinite(float(r[k]))
        assert 0.0 <= float(r["Ap_pct"]) <= 100.0 and float(r["max_damage"]) >= 0.0


@pytest.mark.slow
def test_a_failing_item_is_named_in_the_error(tmp_path, capsys):
    """A contact that cannot converge stops the run with the item, position, k_lub and
    block in the message, not only the solver's words."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["lubrication"] = {"max_iterations": 10, "tolerance": 1e-14}
    scene = write_scene(tmp_path / "s.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) != 0
    err = capsys.readouterr().err
    assert "item 0 (position 1, k_lub 0 s, roughness × 1, patch 0), block 1:" in err
    assert "did not converge" in err
