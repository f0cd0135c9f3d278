"""The output folder's lock dies with its holder (issue 30 item 3): a kernel lock (flock) held
by rank 0's process, released by the kernel however that process ends. A restart right after
a kill is accepted (the killed holder may still be a zombie, or exiting), a second run beside a
live one is refused naming the holder."""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time

import pytest
from helpers import ROOT, environment, tiny_doc, wait_for_text, write_scene

from micropit_hpc.errors import MicropitError
from micropit_hpc.io import outdir

HOLD = """
import sys, time
from pathlib import Path
from micropit_hpc.io.outdir import OutputLock
OutputLock(Path(sys.argv[1])).acquire()
print("locked", flush=True)
time.sleep(600)
"""


def hold_lock(out):
    """A child process that takes the lock of ``out`` and sleeps."""
    out.mkdir(parents=True, exist_ok=True)
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(out)], env=environment(),
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "locked"
    return proc


def test_a_live_holder_is_refused_and_its_kill_frees_the_lock_at_once(tmp_path):
    """While the holder lives a second lock is refused (after waiting), naming it; once it is
    SIGKILLed — and not yet reaped: a zombie, which ``kill(pid, 0)`` still finds — the lock is
    free at once."""
    out = tmp_path / "out"
    holder = hold_lock(out)
    try:
        with pytest.raises(MicropitError, match=rf"in use by another run \(host \S+, pid "
                                                rf"{holder.pid}"):
            outdir.OutputLock(out, wait_s=0.3).acquire()
        holder.send_signal(signal.SIGKILL)
        deadline = time.monotonic() + 30      # wait until it is a zombie, without reaping it
        while time.monotonic() < deadline:
            with open(f"/proc/{holder.pid}/stat") as fh:
                if fh.read().rsplit(")", 1)[1].split()[0] == "Z":
                    break
            time.sleep(0.01)
        assert os.path.exists(f"/proc/{holder.pid}")        # still there, as a zombie
        said = []
        lock = outdir.OutputLock(out, said.append, wait_s=0.0)
        lock.acquire()
        assert any("was released when its process ended" in s for s in said), said
        lock.release()
        assert not (out / outdir.LOCK).exists()
    finally:
        holder.kill()
        holder.wait()


def test_a_holder_that_is_still_exiting_is_waited_for(tmp_path):
    """A holder that lets the lock go within the wait (a killed rank still closing its files)
    does not make the next run fail."""
    out = tmp_path / "out"
    holder = hold_lock(out)
    try:
        said = []
        lock = outdir.OutputLock(out, said.append, wait_s=30.0)
        threading_kill = subprocess.Popen(["sh", "-c", f"sleep 0.5; kill -9 {holder.pid}"])
        lock.acquire()
        threading_kill.wait()
        assert said[0].startswith(f"waiting up to 30 s for the lock {out / outdir.LOCK}")
        lock.release()
    finally:
        holder.kill()
        holder.wait()


def test_a_released_lock_is_not_taken_twice(tmp_path):
    """Two lockers in one process take turns: release unlinks the file while locked, so one
    that opened the old file must not believe it holds the new one."""
    out = tmp_path / "out"
    out.mkdir()
    a = outdir.OutputLock(out)
    a.acquire()
    b = outdir.OutputLock(out, wait_s=0.0)
    with pytest.raises(MicropitError, match="in use by another run"):
        b.acquire()
    a.release()
    b.acquire()
    c = outdir.OutputLock(out, wait_s=0.0)
    with pytest.raises(MicropitError, match="in use by another run"):
        c.acquire()
    b.release()


def _children(pid):
    """The pids whose parent is ``pid`` (the ranks of an mpirun)."""
    found = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    if int(fh.read().rsplit(")", 1)[1].split()[1]) == pid:
                        found.append(int(d))
            except (OSError, ValueError, IndexError):
                pass
    return sorted(found)


def _scene(tmp_path):
    doc = tiny_doc(slide_roll=(0.15, 0.3))
    doc["life"]["cycles_M"] = 4.0
    return write_scene(tmp_path / "lock.toml", doc)


@pytest.mark.slow
@pytest.mark.timeout(400)
def test_kills_at_random_moments_then_immediate_restarts(tmp_path):
    """One process: SIGKILL at random moments (seeded) of a run, each followed at once by
    ``--restart``, which must get the lock every time; the last one finishes the run."""
    scene, out = _scene(tmp_path), tmp_path / "out"
    rng = random.Random(30)
    base = [sys.executable, "-m", "micropit_hpc", "run", str(scene), "--out", str(out)]
    for trial in range(4):
        log = tmp_path / f"part{trial}.log"
        with open(log, "w") as fh:
            proc = subprocess.Popen(base + (["--restart"] if trial else []), env=environment(),
                                    stdout=fh, stderr=subprocess.STDOUT)
        assert wait_for_text(log, "# estimate:", proc), log.read_text()
        time.sleep(rng.uniform(0.0, 3.0))
        proc.kill()                                          # no wait: restart at once
        text = log.read_text()
        assert "in use by another run" not in text, text
        proc.wait()
    done = subprocess.run([*base, "--restart"], env=environment(), capture_output=True,
                          text=True, timeout=200)
    assert done.returncode == 0, done.stderr
    assert outdir.check_manifest(out) is None and not (out / outdir.LOCK).exists()


@pytest.mark.slow
@pytest.mark.timeout(400)
@pytest.mark.skipif(shutil.which("mpirun") is None, reason="needs mpirun")
@pytest.mark.parametrize("kill", ["whole job", "rank 0", "rank 1", "mpirun",
                                  "inside the checkpoint write"])
def test_an_immediate_restart_after_a_kill_under_mpirun_is_accepted(tmp_path, kill):
    """``mpirun -n 2``, killed in each way (SIGKILL to the whole process group, to one rank,
    to mpirun, or to rank 0 inside the collective checkpoint write), then at once a
    ``--restart`` on 2 ranks: it takes the lock and finishes."""
    scene, out = _scene(tmp_path), tmp_path / "out"
    run = ["run", str(scene), "--out", str(out)]
    fault = ("killckpt", 0) if kill == "inside the checkpoint write" else ("none", 0)
    cmd = ["mpirun", "-n", "2", sys.executable, str(ROOT / "tests" / "fault_run.py"),
           fault[0], str(fault[1]), *run]
    log = tmp_path / "first.log"
    with open(log, "w") as fh:
        proc = subprocess.Popen(cmd, env=environment(), stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
    try:
        if kill == "inside the checkpoint write":
            proc.wait(timeout=200)                           # rank 0 killed itself
        else:
            assert wait_for_text(log, "[progress] 1/", proc), log.read_text()
            ranks = _children(proc.pid)
            assert len(ranks) == 2, ranks
            if kill == "whole job":
                os.killpg(proc.pid, signal.SIGKILL)
            elif kill == "mpirun":
                proc.kill()
            else:                                            # rank 0 holds the lock
                holder = json.loads((out / outdir.LOCK).read_text())["pid"]
                assert holder in ranks
                os.kill(holder if kill == "rank 0" else sum(ranks) - holder, signal.SIGKILL)
        again = subprocess.run(["mpirun", "-n", "2", sys.executable, "-m", "micropit_hpc",
                                *run, "--restart"], env=environment(), capture_output=True,
                               text=True, timeout=250)
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
    assert again.returncode == 0, log.read_text() + again.stderr
    assert "in use by another run" not in again.stderr
    assert outdir.check_manifest(out) is None and not (out / outdir.LOCK).exists()
