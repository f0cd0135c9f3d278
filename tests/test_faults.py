"""Faults under ``mpirun -n 2`` (issue 21 item 1): an error on any rank ends the whole job
within seconds, with its one-line message printed once and a non-zero exit.

Each case launches ``mpirun -n 2`` with a hang guard (helpers.HANG_LIMIT_S: the job would
otherwise spin until killed; no timing is asserted): the solver failing for real on a rank, a
rank failing after the restart read, a rank failing inside the collective checkpoint write,
rank 0 failing to write the results, a bug (KeyError) on rank 1 mid-block, and errors every
rank raises (a bad ``--ranks-per-item``, a repeated ``--position``) which rank 0 reports once
and every rank leaves without ``MPI_Abort``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from helpers import error_lines, mpirun_fault, tiny_doc, write_scene

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")


def scene(tmp_path, name="tiny.toml", **life):
    doc = tiny_doc(slide_roll=(0.15, 0.3))
    doc["life"].update(life)
    return write_scene(tmp_path / name, doc)


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_solver_failure_on_one_rank_ends_the_job(tmp_path):
    """The issue's reproduction: 'did not converge' on a rank used to leave both spinning."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["study"]["roughness_scale"] = [1.0, 0.0001]
    doc["lubrication"] = {"max_iterations": 10, "tolerance": 1e-14}
    path = write_scene(tmp_path / "bad.toml", doc)
    rc, err = mpirun_fault(["run", path, "--out", tmp_path / "out"])
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "did not converge" in lines[0], err
    assert "Traceback" not in err


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_solver_failure_in_a_group_of_two_ranks_ends_the_job(tmp_path):
    """--ranks-per-item 2: the group root fails in the contact solve while its partner waits
    for the step's fields."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["lubrication"] = {"max_iterations": 10, "tolerance": 1e-14}
    path = write_scene(tmp_path / "bad.toml", doc)
    rc, err = mpirun_fault(["run", path, "--out", tmp_path / "out", "--ranks-per-item", "2"])
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "rank 0 of 2" in lines[0] and "did not converge" in lines[0]


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_an_error_wrongly_marked_collective_still_ends_the_job(tmp_path):
    """The safety net: an error marked collective that only rank 1 meets waits
    COLLECTIVE_EXIT_WAIT_S for the others, then aborts, and its message is printed once."""
    from micropit_hpc.cli import COLLECTIVE_EXIT_WAIT_S

    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out"],
                           ("collective", 1))
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "rank 1 of 2: injected fault: a collective error" in lines[0]
    assert f"within {COLLECTIVE_EXIT_WAIT_S:g} s" in lines[0]


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_bug_on_rank_1_mid_block_ends_the_job_with_its_traceback_once(tmp_path):
    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out"], ("internal", 1))
    assert rc == 1, err
    lines = error_lines(err)
    assert lines == ["micropit: error: rank 1 of 2: internal error: KeyError: 'records'"], err
    assert err.count("Traceback") == 1


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_a_failure_on_rank_1_after_the_restart_read_ends_the_job(tmp_path):
    path = scene(tmp_path)
    out = tmp_path / "out"
    stop = tmp_path / "STOP"
    stop.touch()   # one block, checkpoint, exit 85
    rc, err = mpirun_fault(["run", path, "--out", out, "--stop-file", stop])
    assert rc == 85, err
    rc, err = mpirun_fault(["run", path, "--out", out, "--restart"], ("restart", 1))
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and lines[0].startswith("micropit: error: rank 1 of 2: injected"), err


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_failure_inside_the_collective_checkpoint_write_ends_the_job(tmp_path):
    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out"],
                        ("checkpoint", 1))
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "rank 1 of 2: injected fault" in lines[0], err
    assert not list((tmp_path / "out" / "checkpoints").glob("ckpt_*.h5"))


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_failure_writing_the_results_ends_the_job(tmp_path):
    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out"], ("results", 0))
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and "rank 0 of 2: injected fault: cannot write" in lines[0], err


@pytest.mark.slow
@pytest.mark.timeout(120)
@pytest.mark.parametrize("args, text", [
    (["--ranks-per-item", "3"], "--ranks-per-item 3: 2 MPI ranks cannot be split"),
    (["--position", "1", "--position", "1"], "--position 1 is given more than once"),
    (["--position", "7"], "--position 7:"),
])
def test_an_error_every_rank_raises_is_printed_once_without_abort(tmp_path, args, text):
    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out", *args])
    assert rc == 2, err
    lines = error_lines(err)
    assert len(lines) == 1 and text in lines[0], err
    assert "MPI_ABORT" not in err


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_a_damaged_checkpoint_under_mpirun_falls_back(tmp_path):
    """The issue's reproduction: flipped bits in the heights of the newest checkpoint used to
    hang both ranks; now rank 0 skips it (saying why) and both resume from the one before."""
    import h5py

    path = scene(tmp_path, cycles_M=3.0)
    out = tmp_path / "out"
    rc, err = mpirun_fault(["run", path, "--out", out])
    assert rc == 0, err
    ck = out / "checkpoints" / "ckpt_000003.h5"
    with h5py.File(ck, "r") as f:
        info = f["body1/heights"].id.get_chunk_info(0)
    with open(ck, "r+b") as fh:
        fh.seek(info.byte_offset + 100)
        fh.write(b"\xff" * 16)
    rc, err = mpirun_fault(["run", path, "--out", out, "--restart"])
    assert rc == 0, err
    assert f"skipped {ck}" in err and "block 2 of 3" in err
    assert err.count("skipped") == 1 and "Traceback" not in err


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_usage_error_under_mpirun_is_printed_once(tmp_path):
    rc, err = mpirun_fault(["run", scene(tmp_path), "--out", tmp_path / "out", "--max-wall", "nan"])
    assert rc == 2, err
    assert err.count("error: argument --max-wall: the wall-time budget must be a positive, "
                     "finite time, got 'nan'") == 1, err
    assert err.count("usage:") == 1

