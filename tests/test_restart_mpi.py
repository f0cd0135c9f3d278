"""The parallel run contract under ``mpirun -n 2`` (issue 5 item 8, docs/hpc.md §2–§4).

* 2 ranks (groups of 1) stopped after a block and restarted on 2 ranks, and on 1 rank, equal
  the straight 1-rank run bit for bit;
* ranks_per_item = 2 (one window split into x-slabs: mpi4py-fft, DMDA) equals one rank to
  1e-12 relative, also when restarted from a checkpoint written with ranks_per_item = 1, on an
  odd 27 × 27 window (slabs of 14 and 13 rows) where the transforms really differ.

Every verdict is allgathered before it is asserted (a failure on one rank must not hang the
other).
"""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from helpers import tiny_doc

from micropit_hpc.parallel import SerialComm
from micropit_hpc.runner import RunOptions, run_study
from micropit_hpc.scene import scene_from_dict


def agree(comm, ok) -> bool:
    return all(comm.allgather(bool(ok)))


def scene_of(n=32, blocks=3):
    doc = tiny_doc(slide_roll=(0.15, 0.3), k_lub=(0.0, 1e-10))
    doc["life"]["cycles_M"] = float(blocks)
    doc["window"]["n"] = n
    return scene_from_dict(doc, "tiny.toml")


def outcome_data(outcome):
    """Records without wall times, and the final maps (world rank 0; None elsewhere)."""
    maps = outcome.study.gather_maps()
    recs = {i: [replace(r, wall_s=0.0) for r in rs] for i, rs in outcome.records.items()}
    return recs, maps


def serial_reference(scene, out: Path):
    o = run_study(scene, RunOptions(out=out), SerialComm())
    return outcome_data(o)


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_stop_and_restart_on_2_then_1_ranks_equal_the_straight_run(shared_dir):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    scene = scene_of()
    stop = shared_dir / "STOP"
    if comm.rank == 0:
        stop.touch()
    comm.Barrier()
    a = run_study(scene, RunOptions(out=shared_dir / "a", stop_file=stop), comm)
    ok = a.status == "stopped" and a.blocks_done == 1
    comm.Barrier()
    if comm.rank == 0:
        stop.unlink()
        shutil.copytree(shared_dir / "a", shared_dir / "b")       # for the 2 -> 1 restart
    comm.Barrier()
    a = run_study(scene, RunOptions(out=shared_dir / "a", restart=True), comm)
    ok = ok and a.status == "done" and a.start_block == 1
    recs2, maps2 = outcome_data(a)
    if comm.rank == 0:
        ref_recs, ref_maps = serial_reference(scene, shared_dir / "ref")
        b = run_study(scene, RunOptions(out=shared_dir / "b", restart=True), SerialComm())
        recs1, maps1 = outcome_data(b)
        ok = ok and b.start_block == 1
        for recs, maps in ((recs2, maps2), (recs1, maps1)):
            ok = ok and recs == ref_recs and all(
                np.array_equal(maps[i][k], ref_maps[i][k]) for i in ref_maps
                for k in ref_maps[i])
    assert agree(comm, ok)


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_a_window_split_over_two_ranks_equals_one_rank(shared_dir):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    scene = scene_of(n=27, blocks=2)
    # block 1 with items spread over 2 groups of 1, block 2 resumed with one group of 2
    stop = shared_dir / "STOP"
    if comm.rank == 0:
        stop.touch()
    comm.Barrier()
    run_study(scene, RunOptions(out=shared_dir / "r", stop_file=stop), comm)
    comm.Barrier()
    if comm.rank == 0:
        stop.unlink()
    comm.Barrier()
    split = run_study(scene, RunOptions(out=shared_dir / "r", restart=True, ranks_per_item=2),
                      comm)
    ok = split.study.group.size == 2 and split.start_block == 1
    ok = ok and split.study.runs[0].cycle.slab.nx_local == (14 if comm.rank == 0 else 13)
    # the contact's time steps shared over the group's ranks (cycle.contact_parallel "auto")
    ok = ok and split.study.runs[0].cycle.contact_parallel == "steps"
    straight = run_study(scene, RunOptions(out=shared_dir / "s", ranks_per_item=2), comm)
    recs_r, maps_r = outcome_data(split)
    recs_s, maps_s = outcome_data(straight)
    worst = 0.0
    if comm.rank == 0:
        ref_recs, ref_maps = serial_reference(scene, shared_dir / "ref")
        for recs, maps in ((recs_r, maps_r), (recs_s, maps_s)):
            for i in ref_maps:
                # pits and wear are thresholds and sums of replicated fields: equal
                for k in ("body1/pitted", "body2/pitted", "body1/wear", "body2/wear"):
                    ok = ok and np.array_equal(maps[i][k], ref_maps[i][k])
                for k in ("body1/damage", "body2/damage", "body1/heights", "body2/heights"):
                    ref = ref_maps[i][k]
                    worst = max(worst, float(np.abs(maps[i][k] - ref).max()
                                             / np.abs(ref).max()))
                for r, q in zip(recs[i], ref_recs[i], strict=True):
                    ok = ok and r.Ap == q.Ap and r.cycles == q.cycles
                    ok = ok and np.allclose(r.max_damage, q.max_damage, rtol=1e-12, atol=0)
        ok = ok and worst <= 1e-12
        print(f"ranks_per_item 2 vs 1: largest relative difference {worst:.2e}")
    assert agree(comm, ok)


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_a_rank_without_items_checkpoints_and_restarts(shared_dir):
    """One work item on two groups: rank 1 computes nothing and writes nothing, yet takes part
    in every collective write and read (docs/hpc.md §3)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(0.0,))
    doc["life"]["cycles_M"] = 2.0
    scene = scene_from_dict(doc, "one.toml")
    stop = shared_dir / "STOP"
    if comm.rank == 0:
        stop.touch()
    comm.Barrier()
    a = run_study(scene, RunOptions(out=shared_dir / "o", stop_file=stop), comm)
    # the item runs on the group that took it from the queue (docs/hpc.md §2)
    ok = a.status == "stopped" and sum(comm.allgather(len(a.study.runs))) == 1
    comm.Barrier()
    if comm.rank == 0:
        stop.unlink()
    comm.Barrier()
    b = run_study(scene, RunOptions(out=shared_dir / "o", restart=True), comm)
    recs, maps = outcome_data(b)
    ok = ok and b.status == "done" and b.start_block == 1
    if comm.rank == 0:
        ref_recs, ref_maps = serial_reference(scene, shared_dir / "ref")
        ok = ok and recs == ref_recs and all(np.array_equal(maps[0][k], ref_maps[0][k])
                                             for k in ref_maps[0])
    assert agree(comm, ok)
