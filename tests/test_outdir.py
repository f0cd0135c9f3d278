"""One run per output folder (issue 21 item 5) and the one-line refusals of bad options
(item 6): the lock file and its stale detection, a finished folder refused unless --restart or
--overwrite, summary.csv and results.h5 published together under a manifest written last, and
files created with the umask's modes."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.io import outdir

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    d = tmp_path_factory.mktemp("outdir")
    doc = tiny_doc(slide_roll=(0.3,))
    scene = write_scene(d / "tiny.toml", doc)
    assert main(["run", str(scene), "--out", str(d / "out")]) == 0
    return scene, d / "out"


def run(scene, out, *extra):
    return main(["run", str(scene), "--out", str(out), *map(str, extra)])


@pytest.mark.slow
def test_a_finished_run_publishes_a_manifest_matching_both_files(finished):
    """summary.csv, results.h5 and the XDMF that describes it appear together."""
    _, out = finished
    m = json.loads((out / outdir.MANIFEST).read_text())
    assert sorted(m["files"]) == ["results.h5", "results.xdmf", "summary.csv"]
    assert m["status"] == "done" and m["blocks_done"] == m["blocks"] == 2
    assert outdir.check_manifest(out) is None
    assert not (out / outdir.LOCK).exists() and not (out / outdir.STAGING).exists()


@pytest.mark.slow
def test_a_fresh_run_into_a_finished_folder_is_refused(finished, tmp_path, capsys):
    import shutil

    scene, ref = finished
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    before = (out / "summary.csv").read_bytes()
    capsys.readouterr()
    assert run(scene, out) == 2
    err = capsys.readouterr().err
    errors = [ln for ln in err.splitlines() if ln.startswith("micropit: error:")]
    assert len(errors) == 1 and "holds another run's results or checkpoints" in errors[0]
    assert "summary.csv" in err and "--restart" in err and "--overwrite" in err
    assert (out / "summary.csv").read_bytes() == before
    # --overwrite clears the old run (stale checkpoints included) and runs afresh
    (out / "checkpoints" / "ckpt_000099.h5").write_bytes(b"old")
    assert run(scene, out, "--overwrite") == 0
    assert "--overwrite: deleted" in capsys.readouterr().err
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "LATEST", "ckpt_000001.h5", "ckpt_000002.h5"]
    # a folder with only checkpoints is another run's too
    (out / "summary.csv").unlink()
    (out / "results.h5").unlink()
    (out / "manifest.json").unlink()
    assert run(scene, out) == 2


def write_lock(out: Path, age_s: float = 0.0, **info):
    out.mkdir(parents=True, exist_ok=True)
    lock = out / outdir.LOCK
    lock.write_text(json.dumps(info))
    t = time.time() - age_s
    os.utime(lock, (t, t))
    return lock


@pytest.fixture
def no_flock(monkeypatch):
    """A file system without flock (ENOLCK): the fallback lock file with its heartbeat."""
    import errno

    def flock(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")
    monkeypatch.setattr(outdir.fcntl, "flock", flock)


@pytest.mark.slow
def test_without_flock_a_live_lock_file_refuses_the_folder(finished, tmp_path, capsys, no_flock):
    scene, _ = finished
    out = tmp_path / "out"
    lock = write_lock(out, host=socket.gethostname(), pid=os.getpid(), job=None)
    assert run(scene, out) == 2
    err = capsys.readouterr().err
    assert f"--out {out} is in use by another run" in err and str(lock) in err
    assert f"pid {os.getpid()}" in err and "has no flock" in err
    write_lock(out, host="elsewhere", pid=1, job=None)   # another host, refreshed recently
    assert run(scene, out) == 2
    assert not (out / "summary.csv").exists()


@pytest.mark.slow
@pytest.mark.parametrize("case", ["dead pid", "reused pid", "old", "same job", "garbage"])
def test_without_flock_a_stale_lock_is_taken_over_with_a_message(finished, tmp_path, capsys,
                                                                 monkeypatch, no_flock, case):
    scene, _ = finished
    out = tmp_path / "out"
    if case == "dead pid":
        p = subprocess.Popen([sys.executable, "-c", "pass"])
        p.wait()
        write_lock(out, host=socket.gethostname(), pid=p.pid, job=None)
    elif case == "reused pid":   # our own pid, but a lock written by an earlier process
        write_lock(out, host=socket.gethostname(), pid=os.getpid(), pid_start="1", job=None)
    elif case == "old":
        write_lock(out, age_s=outdir.STALE_S + 60, host="elsewhere", pid=1, job=None)
    elif case == "same job":
        monkeypatch.setenv("SLURM_JOB_ID", "4242")
        write_lock(out, host="elsewhere", pid=1, job="4242")
    else:
        (out).mkdir()
        (out / outdir.LOCK).write_text("not json")
    assert run(scene, out) == 0
    assert "taking over the stale lock" in capsys.readouterr().err
    assert not (out / outdir.LOCK).exists()


@pytest.mark.slow
def test_a_lock_file_nobody_holds_is_taken_whatever_it_says(finished, tmp_path, capsys):
    """With flock the file's contents decide nothing: a lock file left by a killed run (here
    one naming this very process, which a pid test would call alive) is free."""
    scene, _ = finished
    out = tmp_path / "out"
    write_lock(out, host=socket.gethostname(), pid=os.getpid(), job=None)
    assert run(scene, out) == 0
    assert "was released when its process ended: taking it" in capsys.readouterr().err
    assert not (out / outdir.LOCK).exists()


@pytest.mark.slow
@pytest.mark.parametrize("what", [".publish", "checkpoints", "summary.csv", "results.h5",
                                  "checkpoints/LATEST", outdir.EXIT_RECORD])
def test_an_obstruction_in_the_output_folder_is_refused_before_the_first_block(
        finished, tmp_path, capsys, monkeypatch, what):
    """A file where the run makes a folder (the staging folder .publish/ used to end a
    finished run with a traceback; a file named checkpoints was found after block 1), or a
    folder where it writes a file: one line naming it, before any block."""
    from micropit_hpc import study

    def no_block(*a, **k):
        raise AssertionError("a block was computed")
    monkeypatch.setattr(study.ItemRun, "run_block", no_block)
    scene, _ = finished
    out = tmp_path / "out"
    out.mkdir()
    if what in (".publish", "checkpoints"):
        (out / what).write_text("stray")
    else:
        (out / what).mkdir(parents=True)
    for extra in ((), ("--restart",), ("--overwrite",)):
        assert run(scene, out, *extra) == 2
        errors = [ln for ln in capsys.readouterr().err.splitlines()
                  if ln.startswith("micropit: error:")]
        assert len(errors) == 1 and str(out / what) in errors[0], errors
        assert "remove or rename it" in errors[0]


@pytest.mark.slow
@pytest.mark.slow
def test_the_exit_record_notes_a_signal_at_once_then_the_exit_code(finished, tmp_path,
                                                                   monkeypatch):
    """Rank 0 writes "signal N" into OUT/.micropit.exit as the signal arrives (mid-block), then
    85 after the checkpoint; a finished run writes 0."""
    import signal

    from micropit_hpc import study

    scene, _ = finished
    written = []
    real_write = outdir.write_exit_record
    monkeypatch.setattr(outdir, "write_exit_record",
                        lambda out, code: written.append(code) or real_write(out, code))
    real_block = study.ItemRun.run_block

    def block_with_a_signal(self, *a, **k):
        if not written:
            os.kill(os.getpid(), signal.SIGUSR1)
        return real_block(self, *a, **k)
    monkeypatch.setattr(study.ItemRun, "run_block", block_with_a_signal)
    out = tmp_path / "out"
    assert run(scene, out) == 85
    assert written == [f"signal {int(signal.SIGUSR1)}", 85]
    assert (out / outdir.EXIT_RECORD).read_text() == "85\n"
    monkeypatch.setattr(study.ItemRun, "run_block", real_block)
    assert run(scene, out, "--restart") == 0
    assert (out / outdir.EXIT_RECORD).read_text() == "0\n"


def test_quiet_silences_the_progress_only(finished, tmp_path, capsys):
    """--quiet used to hide the checkpoint fallback too: "every checkpoint damaged, start
    afresh" happened without a word."""
    import shutil

    scene, ref = finished
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    with open(out / "checkpoints" / "ckpt_000002.h5", "r+b") as fh:
        fh.truncate(100)                                   # torn: falls back to block 1
    capsys.readouterr()
    assert run(scene, out, "--restart", "--quiet") == 0
    err = capsys.readouterr().err
    assert f"skipped {out / 'checkpoints' / 'ckpt_000002.h5'}" in err
    assert "# estimate:" in err and "[progress]" not in err


@pytest.mark.slow
@pytest.mark.timeout(200)
def test_two_runs_started_into_one_folder(tmp_path):
    """The second run waits for the lock (outdir.LOCK_WAIT_S), then is refused naming the
    live first one, which then stops cleanly."""
    doc = tiny_doc(slide_roll=(0.3, 0.15))
    # long enough to outlast the second run's wait on any machine (100 blocks took 11 s
    # here, against the second run's ~13 s); the STOP file ends it at the next block
    doc["life"]["cycles_M"] = 2000.0
    scene = write_scene(tmp_path / "t.toml", doc)
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "micropit_hpc", "run", str(scene), "--out", str(out)]
    first = subprocess.Popen([*cmd, "--stop-file", str(tmp_path / "STOP")], env=env,
                             stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (out / outdir.LOCK).exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    second = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=90)
    (tmp_path / "STOP").touch()
    _, err1 = first.communicate(timeout=90)
    assert first.returncode == 85, err1
    assert second.returncode == 2, second.stderr
    assert f"is in use by another run (host {socket.gethostname()}, pid {first.pid}" \
        in second.stderr
    assert "waiting up to" in second.stderr


def test_a_kill_between_the_renames_leaves_no_manifest(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / outdir.MANIFEST).write_text("{}")   # the previous publication's
    st = outdir.staging(out)
    (st / "summary.csv").write_text("a\n")
    (st / "results.h5").write_text("b\n")
    real = os.replace
    calls = []

    def dies_second_time(a, b):
        calls.append(b)
        if len(calls) == 2:
            raise KeyboardInterrupt("killed")
        real(a, b)
    monkeypatch.setattr(outdir.os, "replace", dies_second_time)
    with pytest.raises(KeyboardInterrupt):
        outdir.publish(out, ("summary.csv", "results.h5"), {})
    assert not (out / outdir.MANIFEST).exists()
    assert "manifest.json" in outdir.check_manifest(out)   # readers know the pair is torn


@pytest.mark.slow
@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_files_follow_the_umask(finished, tmp_path, mask, mode):
    scene, _ = finished
    out = tmp_path / "out"
    old = os.umask(mask)
    try:
        assert run(scene, out) == 0
    finally:
        os.umask(old)
    for name in ("summary.csv", "results.h5", "manifest.json", "checkpoints/LATEST",
                 "checkpoints/ckpt_000002.h5"):
        assert oct((out / name).stat().st_mode & 0o777) == oct(mode), name


@pytest.mark.slow
@pytest.mark.parametrize("args, text", [
    (["--out", ""], "expected a folder name, got an empty one"),
    (["--out", "X", "--force"], "--force only applies with --restart"),
    (["--out", "X", "--restart", "--overwrite"], "give one of them"),
    (["--out", "X", "--max-wall", "nan"], "positive, finite time, got 'nan'"),
    (["--out", "X", "--max-wall", "inf"], "positive, finite time, got 'inf'"),
    (["--out", "X", "--max-wall", "-1"], "positive, finite time, got '-1'"),
    (["--out", "X", "--max-wall", "1-x"], "expected seconds or [D-]H:M:S, got '1-x'"),
    (["--out", "X", "-micropit_checkpoint_keep", "abc"],
     "-micropit_checkpoint_keep abc: expected a whole number ≥ 1"),
    (["--out", "X", "-micropit_checkpoint_every", "0"],
     "-micropit_checkpoint_every 0: expected a whole number ≥ 1"),
])
def test_bad_options_are_one_line_errors(finished, tmp_path, capsys, monkeypatch, args, text):
    scene, _ = finished
    monkeypatch.chdir(tmp_path)
    parse_error = args[1] == "" or "--max-wall" in args   # argparse's own exit 2
    with pytest.raises(SystemExit) if parse_error else _nothing():
        rc = main(["run", str(scene), *args])
        assert rc == 2
    err = capsys.readouterr().err
    assert text in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())   # nothing written


@pytest.fixture(autouse=True)
def _forget_petsc_options():
    """PETSc's options database outlives one main() call in this process: clear ours."""
    yield
    import sys as _sys

    if "petsc4py.PETSc" in _sys.modules:
        opts = _sys.modules["petsc4py.PETSc"].Options()
        for key in ("micropit_checkpoint_keep", "micropit_checkpoint_every"):
            if opts.hasName(key):
                opts.delValue(key)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False
