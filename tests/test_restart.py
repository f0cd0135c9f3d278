"""micropit run: checkpoints, restart, clean stops (docs/hpc.md §3; issue 5 items 4, 5 and 8).

A run stopped after k blocks (STOP file, wall-time budget, SIGUSR1, SIGKILL) and restarted must
give the same summary.csv and results.h5 as the straight run, bit for bit.
"""

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import environment, results_differ, tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.io.checkpoint import find_latest
from micropit_hpc.parallel.control import EXIT_CHECKPOINTED
from micropit_hpc.state import RECORD_FIELDS, record_from_row, record_row

ROOT = Path(__file__).resolve().parents[1]


def tiny3(**kw):
    doc = tiny_doc(slide_roll=(0.15, 0.3), k_lub=(0.0, 1e-10), **kw)
    doc["life"]["cycles_M"] = 3.0
    return doc


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    """The straight 3-block run of the tiny study (4 items)."""
    d = tmp_path_factory.mktemp("straight")
    scene = write_scene(d / "tiny.toml", tiny3())
    assert main(["run", str(scene), "--out", str(d / "out")]) == 0
    return scene, d / "out"


@pytest.mark.slow
def test_record_rows_round_trip(straight):
    _, out = straight
    with h5py.File(out / "checkpoints" / "ckpt_000003.h5", "r") as f:
        tab = f["records"][()]
    assert tab.shape == (4, 3, len(RECORD_FIELDS))
    for row in tab.reshape(-1, len(RECORD_FIELDS)):
        assert np.array_equal(record_row(record_from_row(row)), row)


@pytest.mark.slow
def test_a_stopped_and_restarted_run_equals_the_straight_run(straight, tmp_path, capsys):
    scene, ref = straight
    stop = tmp_path / "STOP"
    stop.touch()
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--stop-file", str(stop)]) == \
        EXIT_CHECKPOINTED
    err = capsys.readouterr().err
    assert "stopping after block 1 of 3: STOP file" in err
    assert find_latest(out / "checkpoints") == out / "checkpoints" / "ckpt_000001.h5"
    with h5py.File(out / "results.h5", "r") as f:        # partial results say so
        assert f.attrs["status"] == "stopped" and f.attrs["blocks_done"] == 1
    stop.unlink()
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    assert "restarted from" in capsys.readouterr().err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_restart_skips_a_torn_checkpoint_and_a_leftover_tmp(straight, tmp_path, capsys):
    scene, ref = straight
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    ck = out / "checkpoints"
    newest = ck / "ckpt_000003.h5"
    data = newest.read_bytes()
    newest.write_bytes(data[: len(data) // 2])           # torn: the writer died mid-way
    shutil.copy(ck / "ckpt_000002.h5", ck / "ckpt_000004.h5.tmp")   # a stale temporary
    (out / "results.h5").unlink()
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    err = capsys.readouterr().err
    assert "ckpt_000003.h5" in err and "skipped" in err
    assert "block 2 of 3" in err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_a_different_scene_is_refused_unless_forced(straight, tmp_path, capsys):
    scene, ref = straight
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    for p in sorted((out / "checkpoints").glob("ckpt_00000[23].h5")):
        p.unlink()
    doc = tiny3()
    doc["fatigue"] = {"woehler_B_MPa": 1650.0}
    other = write_scene(tmp_path / "other.toml", doc)
    assert main(["run", str(other), "--out", str(out), "--restart"]) == 2
    err = capsys.readouterr().err
    assert "different scene" in err and "fatigue" in err and "--force" in err
    assert main(["run", str(other), "--out", str(out), "--restart", "--force"]) == 0
    # the work items must match even with --force
    assert main(["run", str(scene), "--out", str(out), "--restart", "--force",
                 "--position", "1"]) == 2
    assert "other work items" in capsys.readouterr().err


@pytest.mark.slow
def test_restart_without_a_checkpoint_starts_afresh(straight, tmp_path, capsys):
    scene, ref = straight
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    assert "no usable checkpoint" in capsys.readouterr().err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_the_wall_time_budget_stops_at_a_block_boundary(straight, tmp_path, capsys):
    scene, _ = straight
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--max-wall", "0:00:00.5"]) == \
        EXIT_CHECKPOINTED
    assert "wall-time budget 0.5 s" in capsys.readouterr().err
    assert find_latest(out / "checkpoints") is not None


@pytest.mark.slow
@pytest.mark.parametrize("value", ["0", "-5", "1:2:3:4", "ten"])
def test_a_bad_wall_time_is_a_clear_error(tmp_path, capsys, value):
    with pytest.raises(SystemExit):
        main(["run", "x.toml", "--out", str(tmp_path), "--max-wall", value])
    assert "--max-wall" in capsys.readouterr().err


@pytest.mark.slow
def test_unknown_double_dash_options_are_still_errors(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["run", "x.toml", "--out", str(tmp_path), "--restat"])
    assert "unrecognized arguments: --restat" in capsys.readouterr().err


def _start_and_signal(cmd, sig, tmp_path):
    """Start ``cmd``, wait for its first progress line (block 1 done), send ``sig``."""
    log = open(tmp_path / "stderr.txt", "w+")
    proc = subprocess.Popen(cmd, env=environment(), stdout=subprocess.DEVNULL, stderr=log,
                            text=True)
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        log.seek(0)
        if "[progress] 1/" in log.read():
            break
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    proc.send_signal(sig)
    rc = proc.wait(timeout=120)
    log.seek(0)
    return rc, log.read()


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_sigusr1_checkpoints_and_exits_85_then_restart_equals_straight(straight, tmp_path):
    scene, ref = straight
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "micropit_hpc", "run", str(scene), "--out", str(out)]
    rc, err = _start_and_signal(cmd, signal.SIGUSR1, tmp_path)
    assert rc == EXIT_CHECKPOINTED, err
    assert "signal SIGUSR1" in err
    assert find_latest(out / "checkpoints") is not None
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    assert results_differ(ref, out) == []


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_a_killed_run_restarts_to_the_straight_result(straight, tmp_path):
    scene, ref = straight
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "micropit_hpc", "run", str(scene), "--out", str(out)]
    rc, err = _start_and_signal(cmd, signal.SIGKILL, tmp_path)
    assert rc == -signal.SIGKILL, err
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    assert results_differ(ref, out) == []


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
def test_sigusr1_to_mpirun_stops_both_ranks_with_85(straight, tmp_path):
    """The batch-job path: Slurm signals the launcher, mpirun forwards SIGUSR1 to the ranks,
    they agree at the block boundary, checkpoint together and exit 85; mpirun returns 85."""
    scene, ref = straight
    out = tmp_path / "out"
    cmd = ["mpirun", "-n", "2", sys.executable, "-m", "micropit_hpc", "run", str(scene),
           "--out", str(out)]
    rc, err = _start_and_signal(cmd, signal.SIGUSR1, tmp_path)
    assert rc == EXIT_CHECKPOINTED, err
    latest = find_latest(out / "checkpoints")
    with h5py.File(latest, "r") as f:
        assert f.attrs["ranks"] == 2
    # and a 1-rank restart of the 2-rank checkpoint finishes the straight run
    assert main(["run", str(scene), "--out", str(out), "--restart"]) == 0
    assert results_differ(ref, out) == []
