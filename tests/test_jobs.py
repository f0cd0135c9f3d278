"""Stops through the job scripts (issue 21 item 4, issue 30 item 2): SIGTERM and SIGUSR1 sent to
the script, to its mpirun, or to the whole process group (as a time limit or ``scancel``
delivers it) end every job script — jobs/local.sh, jobs/slurm_array.sh,
jobs/slurm_big_window.sh, jobs/pbs.sh — in a checkpoint and exit 85, and the batch scripts
requeue (fake ``scontrol``/``squeue``/``qsub`` on PATH record it); the restart then finishes the
run. A signal while the results are written leaves exit 0 and complete results."""

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
needs_mpirun = pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")

#: Seconds mpirun leaves the ranks after it is signalled itself (jobs/forward.sh): short here,
#: where a block takes about a second.
GRACE_S = "4"


def scene(tmp_path, blocks=4):
    doc = tiny_doc(slide_roll=(0.15, 0.3))
    doc["life"]["cycles_M"] = float(blocks)
    return write_scene(tmp_path / "jobtiny.toml", doc)


def _mpirun_child(pid):
    """The pid of the mpirun that ``pid`` (a job script) started, or None."""
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
                with open(f"/proc/{d}/comm") as fh:
                    comm = fh.read().strip()
            except OSError:
                continue
            if int(fields[1]) == pid and comm in ("mpirun", "orterun", "mpiexec"):
                return int(d)
    return None


def start_and_signal(cmd, env, sig, log_path, after="[progress] 1/", to="script"):
    """Start ``cmd`` (in its own session, as a batch system would), wait for ``after`` in its
    output, send ``sig`` to the script, its mpirun or the whole process group (``to``);
    returns (exit code, output)."""
    log = open(log_path, "w+")
    proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, text=True,
                            cwd=ROOT, start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        log.seek(0)
        if after in log.read():
            break
        time.sleep(0.05)
    if to == "script":
        proc.send_signal(sig)
    elif to == "group":
        os.killpg(proc.pid, sig)
    else:
        launcher = _mpirun_child(proc.pid)
        assert launcher is not None, "no mpirun under the script"
        os.kill(launcher, sig)
    try:
        rc = proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("hang after the signal")
    log.seek(0)
    return rc, log.read()


def job_env(tmp_path, **extra):
    env = environment()
    for v in ("SLURM_JOB_ID", "PBS_JOBID", "SLURM_JOB_END_TIME", "SLURM_RESTART_COUNT"):
        env.pop(v, None)
    env.update(MICROPIT_PYTHON=sys.executable, NP="2", KILL_GRACE_S=GRACE_S, **extra)
    return env


FAKE = {  # batch-system commands that record their arguments in $FAKE_LOG
    "scontrol": 'echo "scontrol $*" >> "$FAKE_LOG"',
    "squeue": 'date -u -d "+1 hour" +%Y-%m-%dT%H:%M:%S',
    "qsub": 'echo "qsub $*" >> "$FAKE_LOG"; echo 124.fake',
    "qstat": "exit 1",
}


def fake_batch_system(tmp_path, env):
    """Put fake scontrol, squeue, qsub and qstat first on PATH; returns their log."""
    bin_dir = tmp_path / "fakebin"
    bin_dir.mkdir()
    for name, body in FAKE.items():
        (bin_dir / name).write_text(f"#!/bin/sh\n{body}\n")
        (bin_dir / name).chmod(0o755)
    log = tmp_path / "fake.log"
    log.write_text("")
    env.update(PATH=f"{bin_dir}{os.pathsep}{env['PATH']}", FAKE_LOG=str(log))
    return log


def job(script, tmp_path, path):
    """(command, environment, output folder, requeue line) of ``script`` under a fake batch
    system (Slurm job 4242 or PBS job 77.fake)."""
    if script == "local":
        out = tmp_path / "local"
        env = job_env(tmp_path, OUT_DIR=str(out))
        return ["bash", "jobs/local.sh", str(path)], env, out, None
    if script == "pbs":
        out = tmp_path / "pbs"
        env = job_env(tmp_path, SCENE=str(path), OUT_DIR=str(out), WALLTIME="01:00:00",
                      PBS_JOBID="77.fake")
        return ["bash", "jobs/pbs.sh"], env, out, "qsub -W depend=afterany:77.fake"
    env = job_env(tmp_path, OUT_ROOT=str(tmp_path / "runs"), SLURM_JOB_ID="4242",
                  SLURM_SUBMIT_DIR=str(ROOT))
    if script == "slurm_array":
        return (["bash", "jobs/slurm_array.sh", str(path)], env,
                tmp_path / "runs" / "jobtiny", "scontrol requeue 4242")
    env["POSITION"] = "2"
    return (["bash", "jobs/slurm_big_window.sh", str(path)], env,
            tmp_path / "runs" / "jobtiny" / "position_2", "scontrol requeue 4242")


@pytest.mark.slow
@needs_mpirun
@pytest.mark.timeout(200)
@pytest.mark.parametrize("to", ["script", "mpirun", "group"])
@pytest.mark.parametrize("script", ["local", "slurm_array", "slurm_big_window", "pbs"])
def test_sigterm_ends_every_job_script_in_a_checkpoint_and_exit_85(tmp_path, script, to):
    """SIGTERM to the script, to its mpirun (after KILL_GRACE_S mpirun passes it on) or to
    the whole process group: a checkpoint, exit 85, and the batch scripts requeue."""
    # long enough that the signal always finds the run busy: mpirun passes it on only after
    # KILL_GRACE_S, and on an idle machine 40 blocks of this scene took 4 s in all
    path = scene(tmp_path, blocks=400)
    cmd, env, out, requeue = job(script, tmp_path, path)
    fake = fake_batch_system(tmp_path, env)
    rc, text = start_and_signal(cmd, env, signal.SIGTERM, tmp_path / "job.log", to=to)
    assert rc == 85, text
    latest = find_latest(out / "checkpoints")
    assert latest is not None, text
    assert "signal SIGTERM" in text or "signal SIGUSR1" in text or "stands" in text, text
    if requeue is not None:
        assert requeue in fake.read_text(), text + fake.read_text()
    else:
        assert "RESTART=1 bash jobs/local.sh" in text


SETTLE = """
set -u
EXIT_CHECKPOINTED=85
log() { echo "$*"; }
source jobs/forward.sh
out=$1 rc=$2 _forward_stop=$3
_settle_exit "$out"
echo "rc=$rc"
"""


@pytest.mark.parametrize("launcher, record, stop, latest, want", [
    (1, "85", 0, True, 85),      # mpirun's 1 after a group signal; the run said 85
    (1, "0", 0, True, 0),        # the run finished; mpirun was signalled at the end
    (1, None, 1, True, 85),      # ranks killed mid-block after a stop signal: last checkpoint
    (137, None, 0, True, 85),    # the launcher killed by a signal
    (1, "signal 15", 0, True, 85),   # SIGTERM to mpirun only: rank 0 noted it, ranks killed
    (1, "signal 15", 0, False, 1),   # ... before any checkpoint: a failure
    (1, None, 1, False, 1),      # no checkpoint yet: a failure
    (1, None, 0, True, 1),       # no signal: a failure (a bug), not a requeue
    (2, "85", 1, True, 2),       # a user error stays one
    (85, None, 0, True, 85),
])
def test_the_exit_code_a_job_script_settles_on(tmp_path, launcher, record, stop, latest, want):
    """jobs/forward.sh's rule: the launcher's code unless the run's own record or a stop
    signal with a complete checkpoint says more."""
    out = tmp_path / "out"
    (out / "checkpoints").mkdir(parents=True)
    if record is not None:
        (out / outdir.EXIT_RECORD).write_text(record + "\n")
    if latest:
        (out / "checkpoints" / "LATEST").write_text("ckpt_000003.h5\n")
    p = subprocess.run(["bash", "-c", SETTLE, "settle", str(out), str(launcher), str(stop)],
                       cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert p.stdout.strip().endswith(f"rc={want}"), p.stdout + p.stderr


@pytest.mark.slow
@needs_mpirun
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


@pytest.mark.slow
@needs_mpirun
@pytest.mark.timeout(300)
def test_sigusr1_to_the_local_script_checkpoints_and_restart_finishes(tmp_path):
    """jobs/local.sh passes SIGUSR1 on (it used to die of it, 138, while the run went on) and
    exits 85; RESTART=1 finishes the run."""
    path = scene(tmp_path, blocks=6)
    out = tmp_path / "local"
    env = job_env(tmp_path, OUT_DIR=str(out))
    cmd = ["bash", "jobs/local.sh", str(path)]
    rc, text = start_and_signal(cmd, env, signal.SIGUSR1, tmp_path / "job.log")
    assert rc == 85, text
    assert "stopped with a checkpoint (exit 85)" in text
    p = subprocess.run(cmd, env=dict(env, RESTART="1"), cwd=ROOT, capture_output=True,
                       text=True, timeout=240)
    assert p.returncode == 0, p.stdout + p.stderr
    assert outdir.check_manifest(out) is None


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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
@needs_mpirun
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
