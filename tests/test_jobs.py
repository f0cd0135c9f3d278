"""Stops through the job scripts (issue 21 item 4): SIGTERM and SIGUSR1 sent to the batch shell
of jobs/slurm_array.sh and jobs/pbs.sh (outside Slurm/PBS: no requeue) reach the ranks through
the launcher's relay, so the run checkpoints and the script exits 85; the restart then finishes
the run. A signal while the results are written leaves exit 0 and complete results."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import environment, tiny_doc, write_scene

from micropit_hpc.io import outdir
from micropit_hpc.io.checkpoint import find_latest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")


def scene(tmp_path, blocks=4):
    doc = tiny_doc(slide_roll=(0.15, 0.3))
    doc["life"]["cycles_M"] = float(blocks)
    return write_scene(tmp_path / "jobtiny.toml", doc)


def start_and_signal(cmd, env, sig, log_path, after="[progress] 1/"):
    """Start ``cmd`` (in its own session, as a batch system would), wait for ``after`` in its
    output, send ``sig`` to the batch shell only; returns (exit code, output)."""
    log = open(log_path, "w+")
    proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, text=True,
                            cwd=ROOT, start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        log.seek(0)
        if after in log.read():
            break
        time.sleep(0.05)
    proc.send_signal(sig)
    try:
        rc = proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("hang after the signal")
    log.seek(0)
    return rc, log.read()


def job_env(tmp_path, **extra):
    env = environment()
    env.update(MICROPIT_PYTHON=sys.executable, NP="2", **extra)
    for v in ("SLURM_JOB_ID", "PBS_JOBID", "SLURM_JOB_END_TIME"):
        env.pop(v, None)
    return env


@pytest.mark.timeout(300)
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGUSR1])
def test_a_signal_to_the_slurm_script_checkpoints_and_exits_85(tmp_path, sig):
    path = scene(tmp_path)
    env = job_env(tmp_path, OUT_ROOT=str(tmp_path / "runs"))
    cmd = ["bash", "jobs/slurm_array.sh", str(path)]
    rc, out = start_and_signal(cmd, env, sig, tmp_path / "job.log")
    assert rc == 85, out
    assert f"SIG{sig.name[3:]}" in out and "signal SIGUSR1" in out
    assert "checkpointed; not under Slurm, so not requeueing" in out
    run_dir = tmp_path / "runs" / "jobtiny"
    assert find_latest(run_dir / "checkpoints") is not None
    assert not (run_dir / outdir.LOCK).exists()
    # the requeued task (same command) finishes the run from the checkpoint
    p = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "restarted from" in p.stdout + p.stderr
    assert outdir.check_manifest(run_dir) is None


@pytest.mark.timeout(300)
def test_sigterm_to_the_pbs_script_checkpoints_and_exits_85(tmp_path):
    path = scene(tmp_path)
    env = job_env(tmp_path, SCENE=str(path), OUT_DIR=str(tmp_path / "pbs"),
                  WALLTIME="01:00:00")
    rc, out = start_and_signal(["bash", "jobs/pbs.sh"], env, signal.SIGTERM,
                               tmp_path / "job.log")
    assert rc == 85, out
    assert "checkpointed; not under PBS, so not resubmitting" in out
    assert find_latest(tmp_path / "pbs" / "checkpoints") is not None


WRITE_SLOWLY = """
import os, signal, sys, time
import micropit_hpc.io.results as res
real = res.write_results
def slow(*a, **k):
    os.kill(os.getpid(), signal.SIGUSR1)   # the signal arrives while results.h5 is written
    time.sleep(0.5)
    return real(*a, **k)
res.write_results = slow
sys.argv[0] = "micropit"
from micropit_hpc.cli import main
rc = main()
os.kill(os.getpid(), signal.SIGUSR1)      # and once more after main(), before the exit
sys.exit(rc)
"""


@pytest.mark.timeout(120)
def test_a_signal_while_the_results_are_written_is_harmless(tmp_path):
    path = scene(tmp_path, blocks=2)
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-c", WRITE_SLOWLY, "run", str(path), "--out",
                        str(out)], env=environment(), capture_output=True, text=True,
                       timeout=100)
    assert p.returncode == 0, p.stderr
    assert "signal 10 arrived after the last block; the results are complete" in p.stderr
    assert outdir.check_manifest(out) is None


def test_the_budget_reserves_the_longest_measured_block_plus_a_checkpoint(tmp_path):
    """The stop decision is asked with 1.2 × the longest block so far (its checkpoint
    included) plus the last checkpoint's time: measured, not a fixed margin."""
    from micropit_hpc.parallel import SerialComm
    from micropit_hpc.runner import NEXT_BLOCK_MARGIN, RunOptions, run_study
    from micropit_hpc.scene import scene_from_dict

    asked = []

    class Control:
        max_wall_s, stop_file, signal_received = None, None, 0

        def reason(self, next_block_s=0.0):
            asked.append(next_block_s)
            return None

    doc = tiny_doc(slide_roll=(0.3,))
    doc["life"]["cycles_M"] = 3.0
    sc = scene_from_dict(doc, "t.toml")
    o = run_study(sc, RunOptions(out=tmp_path), SerialComm(), control=Control())
    walls = [r.wall_s for r in o.records[0]]
    assert len(asked) == 2            # after blocks 1 and 2, not after the last
    assert asked[0] > NEXT_BLOCK_MARGIN * walls[0]
    assert asked[1] >= asked[0] * 0.5 and asked[1] > NEXT_BLOCK_MARGIN * max(walls[:2])


@pytest.mark.timeout(300)
def test_the_big_window_script_splits_one_position_over_every_rank(tmp_path):
    """jobs/slurm_big_window.sh runs one position with --ranks-per-item = all ranks, through
    jobs/slurm_array.sh in positions mode (outside Slurm: NP ranks, no requeue)."""
    from micropit_hpc.io.results import load_results

    path = scene(tmp_path, blocks=1)
    env = job_env(tmp_path, OUT_ROOT=str(tmp_path / "runs"), POSITION="2")
    p = subprocess.run(["bash", "jobs/slurm_big_window.sh", str(path)], env=env, cwd=ROOT,
                       capture_output=True, text=True, timeout=240)
    assert p.returncode == 0, p.stdout + p.stderr
    res = load_results(tmp_path / "runs" / "jobtiny" / "position_2")
    assert res.attrs["ranks"] == 2 and res.attrs["ranks_per_item"] == 2
    assert list(res.items["position"]) == [2]
