"""One run per output folder (docs/jobs.md "The output folder").

* A lock: rank 0 opens ``OUT/.micropit.lock`` and holds an exclusive kernel lock on it
  (``flock``) for as long as its process lives, with the holder written inside (host, pid,
  batch job id, start time). The kernel releases the lock the moment the holder's process ends,
  however it ends (SIGKILL, ``MPI_Abort``, a node's process killed inside the checkpoint
  write): a restart right after a kill is accepted, with no liveness guess (a zombie or an
  exiting rank still answers ``kill(pid, 0)``). A second run into the folder is refused naming
  the holder, after waiting up to :data:`LOCK_WAIT_S` s for a holder that is just exiting.
  Where the file system has no ``flock`` (some parallel file systems), the lock falls back to a
  file created exclusively and refreshed every :data:`HEARTBEAT_S` s, *stale* (taken over, with
  a message) when its process is gone (same host), when it was left by this batch job before a
  requeue or by the job named in ``MICROPIT_PREVIOUS_JOB`` (the PBS chain), or when it was not
  refreshed for :data:`STALE_S` s (a dead run on another host).
* A fresh run (no ``--restart``) refuses a folder holding results or checkpoints unless
  ``--overwrite``, which deletes exactly those (:data:`RUN_FILES`, ``checkpoints/``).
* :func:`publish` makes summary.csv and results.h5 appear together: both are written in
  ``OUT/.publish/``, ``manifest.json`` is removed, both are renamed into ``OUT``, the folder is
  fsynced and a new ``manifest.json`` (sizes and SHA-256 of both, blocks done, status) is
  written last. Without a manifest, or when it does not match, the pair is not one run's.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import fcntl
import hashlib
import json
import os
import shutil
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path

from micropit_hpc.errors import MicropitError
from micropit_hpc.parallel.share import raise_agreed

LOCK = ".micropit.lock"
#: The run's own exit code, written by rank 0 as the run ends (0: finished, 85: checkpointed
#: and stopped; before that ``signal N`` when a stop signal arrived) and removed when the next
#: run starts: a job script reads it when the launcher's exit code says less (mpirun exits 1
#: after a SIGTERM to the whole job, whatever the ranks did, and kills ranks that have not
#: reached the next block boundary in time).
EXIT_RECORD = ".micropit.exit"
MANIFEST = "manifest.json"
STAGING = ".publish"
#: What a run leaves in its folder (besides ``checkpoints/``): refused or cleared by a fresh run.
RUN_FILES = ("summary.csv", "results.h5", "results.xdmf", MANIFEST)
HEARTBEAT_S = 30.0
STALE_S = 600.0
#: Seconds a run waits for the lock of a holder that may be exiting (a killed job's rank 0
#: still closing its files) before it refuses the folder.
LOCK_WAIT_S = 10.0
#: flock errors that mean "this file system has no flock": the fallback lock is used.
_NO_FLOCK = (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS, errno.EINVAL)
JOB_VARS = ("SLURM_JOB_ID", "PBS_JOBID", "LSB_JOBID")


def _job_id() -> str | None:
    return next((os.environ[v] for v in JOB_VARS if os.environ.get(v)), None)


def fsync_path(path: Path) -> None:
    """fsync a file or a directory (for a directory: its entries, e.g. a rename)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _start_time(pid: int) -> str | None:
    """The start time of process ``pid`` (Linux /proc, clock ticks since boot), or None."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stale_reason(info: dict, age_s: float) -> str | None:
    """Why the lock described by ``info`` (age ``age_s`` s since its last refresh) belongs to
    no live run, or None if it may."""
    job = info.get("job")
    if job and job in (_job_id(), os.environ.get("MICROPIT_PREVIOUS_JOB")):
        return f"left by job {job} (this job before a requeue, or the previous job of the chain)"
    if info.get("host") == socket.gethostname():
        pid = info.get("pid")
        if isinstance(pid, int) and not _pid_alive(pid):
            return f"its process {pid} on {info['host']} is gone"
        started = info.get("pid_start")
        if isinstance(pid, int) and started and _start_time(pid) not in (None, started):
            return f"its process {pid} on {info['host']} is gone (the pid is another process now)"
    if age_s > STALE_S:
        return f"not refreshed for {age_s:.0f} s (a live run refreshes it every {HEARTBEAT_S:g} s)"
    return None


class OutputLock:
    """The lock of an output folder, held by rank 0 (see the module docstring)."""

    def __init__(self, out: Path, log: Callable[[str], None] = lambda s: None,
                 wait_s: float | None = None):
        self.path = Path(out) / LOCK
        self.log = log
        self.wait_s = LOCK_WAIT_S if wait_s is None else wait_s
        self._fd: int | None = None        # the flock'ed file, open while the run lives
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def _info(self) -> dict:
        return {"host": socket.gethostname(), "pid": os.getpid(),
                "pid_start": _start_time(os.getpid()), "job": _job_id(),
                "started_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")}

    def _holder(self) -> str:
        try:
            info = json.loads(self.path.read_text())
        except (OSError, ValueError):
            info = None
        if not isinstance(info, dict):
            return "holder not recorded yet"
        return ", ".join(f"{k} {info[k]}" for k in ("host", "pid", "job", "started_utc")
                         if info.get(k)) or "holder not recorded"

    def _in_use(self) -> MicropitError:
        return MicropitError(
            f"--out {self.path.parent} is in use by another run ({self._holder()}; lock file "
            f"{self.path}, held by that run's process): wait for it or use another --out")

    def acquire(self) -> None:
        """Take the folder's lock or raise :class:`MicropitError` naming the holder."""
        deadline = time.monotonic() + self.wait_s
        said = False
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
            except OSError as e:
                raise MicropitError(f"cannot create the lock file {self.path}: "
                                    f"{e.strerror or e}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                if time.monotonic() >= deadline:
                    raise self._in_use() from None
                if not said:
                    self.log(f"waiting up to {self.wait_s:g} s for the lock {self.path} "
                             f"({self._holder()})")
                    said = True
                time.sleep(0.1)
                continue
            except OSError as e:
                os.close(fd)
                if e.errno in _NO_FLOCK:
                    self.log(f"the file system of {self.path} has no flock ({e.strerror}): "
                             f"a lock file with a heartbeat instead")
                    self._acquire_file()
                    return
                raise MicropitError(f"cannot lock {self.path}: {e.strerror or e}") from None
            # locked; but a holder that just released may have unlinked the file we opened:
            # the lock counts only on the file the path names now
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            break
        previous = os.fstat(fd).st_size > 0
        if previous:
            self.log(f"the lock {self.path} of an earlier run ({self._holder()}) was released "
                     f"when its process ended: taking it")
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(self._info()) + "\n").encode(), 0)
        self._fd = fd

    # ---- the fallback lock (no flock): created exclusively, refreshed, stale by rules -----------
    def _acquire_file(self) -> None:
        for _attempt in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666)
            except FileExistsError:
                self._break_if_stale()
                continue
            except OSError as e:
                raise MicropitError(f"cannot create the lock file {self.path}: "
                                    f"{e.strerror or e}") from None
            with os.fdopen(fd, "w") as fh:
                json.dump(self._info(), fh)
                fh.write("\n")
            self._thread = threading.Thread(target=self._beat, daemon=True,
                                            name="micropit-lock")
            self._thread.start()
            return
        raise MicropitError(f"cannot take the lock file {self.path} (it keeps reappearing: "
                            "another run is starting in the same folder)")

    def _break_if_stale(self) -> None:
        try:
            text = self.path.read_text()
            age = time.time() - self.path.stat().st_mtime
        except FileNotFoundError:
            return
        try:
            info = json.loads(text)
            if not isinstance(info, dict):
                raise ValueError
        except ValueError:
            info = {}
        why = stale_reason(info, age) if info else "it is not a micropit lock file"
        if why is None:
            raise MicropitError(
                f"--out {self.path.parent} is in use by another run ({self._holder()}; lock "
                f"file {self.path}): wait for it, use another --out, or, if no run uses this "
                f"folder any more, remove the lock file")
        self.log(f"taking over the stale lock {self.path}: {why}")
        self.path.unlink(missing_ok=True)

    def _beat(self) -> None:
        while not self._stop.wait(HEARTBEAT_S):
            with contextlib.suppress(OSError):
                os.utime(self.path)

    def release(self) -> None:
        """Remove the lock file and let the lock go (also done by the kernel at any exit)."""
        if self._fd is not None:
            self.path.unlink(missing_ok=True)   # while still locked: see acquire()
            os.close(self._fd)
            self._fd = None
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
            self.path.unlink(missing_ok=True)


def check_obstructions(out: Path) -> None:
    """Refuse, before the first block, a folder where something stands in the way of what the
    run writes: a file where ``checkpoints/`` or the staging folder ``.publish/`` goes, a
    folder where a result file, the checkpoint pointer or the exit record goes, or a folder
    (``out`` or ``checkpoints/``) this process cannot write in."""
    out = Path(out)
    found = []
    for name in ("checkpoints", STAGING):
        if (out / name).exists() and not (out / name).is_dir():
            found.append(f"{out / name} is a file, where the run makes its folder "
                         f"{name}/: remove or rename it")
    for name in (*RUN_FILES, EXIT_RECORD, "checkpoints/LATEST"):
        if (out / name).is_dir():
            found.append(f"{out / name} is a folder, where the run writes a file: remove or "
                         f"rename it")
    for d in (out, out / "checkpoints"):
        if d.is_dir() and not os.access(d, os.W_OK | os.X_OK):
            found.append(f"cannot write in {d}")
    if found:
        raise MicropitError(f"--out {out}: " + "; ".join(found))


def write_exit_record(out: Path, code: int | str) -> None:
    """Record the run's exit code in ``out`` (rank 0, after the results or the checkpoint), or
    ``signal N`` when a stop signal arrives (the run may still be killed before its next
    checkpoint: the last one then stands)."""
    from micropit_hpc.io.atomic import write_text_atomic

    text = f"{int(code)}" if isinstance(code, int) else str(code)
    write_text_atomic(Path(out) / EXIT_RECORD, text + "\n")


def run_leftovers(out: Path) -> list[str]:
    """The files of a previous run in ``out`` (results, manifest, checkpoints)."""
    found = [n for n in RUN_FILES if (out / n).exists()]
    ck = out / "checkpoints"
    if ck.is_dir():
        found += [f"checkpoints/{p.name}" for p in sorted(ck.iterdir())
                  if p.name.startswith("ckpt_") or p.name == "LATEST"]
    return found


def clear_run(out: Path) -> None:
    """Delete what :func:`run_leftovers` lists (and the staging folder), nothing else."""
    for n in RUN_FILES:
        (out / n).unlink(missing_ok=True)
    shutil.rmtree(out / "checkpoints", ignore_errors=True)
    shutil.rmtree(out / STAGING, ignore_errors=True)
    fsync_path(out)


def prepare(out: Path, comm, *, restart: bool, overwrite: bool,
            log: Callable[[str], None]) -> OutputLock | None:
    """Create ``out``, take its lock and check (or, with ``overwrite``, clear) what a previous
    run left there; rank 0 decides, every rank gets the verdict (collective). Returns the lock
    on rank 0 (None elsewhere): release it when the run ends."""
    lock, problem = None, None
    if comm.rank == 0:
        try:
            try:
                out.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                raise MicropitError(f"cannot create --out {out}: {e.strerror or e}") from None
            lock = OutputLock(out, log)
            lock.acquire()
            check_obstructions(out)
            (out / EXIT_RECORD).unlink(missing_ok=True)   # the previous run's verdict
            found = run_leftovers(out)
            if found and not restart:
                if not overwrite:
                    shown = ", ".join(found[:4]) + (" …" if len(found) > 4 else "")
                    raise MicropitError(
                        f"--out {out} holds another run's results or checkpoints ({shown}): "
                        f"--restart continues that run, --overwrite deletes them and starts "
                        f"afresh; or choose another --out")
                clear_run(out)
                log(f"--overwrite: deleted {len(found)} files of the previous run in {out}")
        except (MicropitError, OSError) as e:
            if lock is not None:
                lock.release()
                lock = None
            problem = str(e) if isinstance(e, MicropitError) else f"--out {out}: {e}"
    raise_agreed(comm, problem)
    return lock


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def staging(out: Path) -> Path:
    """The folder to write the files of :func:`publish` in (created empty)."""
    d = Path(out) / STAGING
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    return d


def publish(out: Path, names: tuple[str, ...], meta: dict) -> Path:
    """Move ``names`` from :func:`staging` into ``out`` as one publication and write
    ``manifest.json`` last (see the module docstring). Returns the manifest's path."""
    from micropit_hpc.io.atomic import write_text_atomic

    out = Path(out)
    stage = out / STAGING
    files = {n: {"bytes": (stage / n).stat().st_size, "sha256": _sha256(stage / n)}
             for n in names}
    (out / MANIFEST).unlink(missing_ok=True)
    fsync_path(out)
    for n in names:
        os.replace(stage / n, out / n)
    fsync_path(out)
    manifest = {"files": files, **meta,
                "published_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")}
    write_text_atomic(out / MANIFEST, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    fsync_path(out)
    shutil.rmtree(stage, ignore_errors=True)
    return out / MANIFEST


def check_manifest(out: Path) -> str | None:
    """Why summary.csv and results.h5 in ``out`` are not one publication, or None."""
    out = Path(out)
    try:
        manifest = json.loads((out / MANIFEST).read_text())
    except (OSError, ValueError) as e:
        return f"{out / MANIFEST}: {e}"
    for n, want in manifest.get("files", {}).items():
        if not (out / n).is_file() or _sha256(out / n) != want.get("sha256"):
            return f"{out / n} does not match {out / MANIFEST}"
    return None
