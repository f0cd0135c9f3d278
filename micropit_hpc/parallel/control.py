"""Stopping a long job cleanly at a block boundary (docs/hpc.md §3, "Long jobs").

A :class:`StopControl` notes signals (Slurm's ``--signal=B:USR1@300`` forwarded by the job
script, or SIGTERM), and at every block boundary all ranks agree, in one reduction, on whether
to stop: a signal seen by any rank, a STOP file (looked for on rank 0 only, so the ranks need
not share a consistent view of the file system), or a wall-time budget that the next block
would overrun (rank 0's clock). The caller then writes a checkpoint and exits with
:data:`EXIT_CHECKPOINTED`, which the job scripts in ``jobs/`` turn into a requeue.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

EXIT_CHECKPOINTED = 85
"""Exit code of a run that stopped early after writing a checkpoint (requeue and restart)."""

_SIGNAL, _STOP, _WALL, _ELAPSED, _NEXT = range(5)  # slots of the reduced code vector


def _op_max():
    try:
        from mpi4py import MPI
    except ImportError:
        return None  # SerialComm ignores the operation
    return MPI.MAX


class StopControl:
    """Signal handlers plus the collective stop decision; a context manager.

    ``stop_file``: a path whose existence asks the run to stop; ``max_wall_s``: the wall-time
    budget in seconds from ``t_start`` (a ``clock()`` reading, default: now); ``signals``: the
    signals to catch (handlers are installed only in the main thread and the previous handlers
    are restored by :meth:`close`). ``clock`` is injectable for tests.
    """

    def __init__(self, comm, stop_file: str | Path | None = None,
                 max_wall_s: float | None = None, t_start: float | None = None,
                 signals: Iterable[int] = (signal.SIGUSR1, signal.SIGTERM),
                 clock: Callable[[], float] = time.monotonic):
        if max_wall_s is not None and not max_wall_s > 0:
            raise ValueError(f"max_wall_s must be positive, got {max_wall_s}")
        self.comm = comm
        self.stop_file = None if stop_file is None else Path(stop_file)
        self.max_wall_s = None if max_wall_s is None else float(max_wall_s)
        self.clock = clock
        self.t_start = clock() if t_start is None else float(t_start)
        self._signum = 0
        #: called with the signal number at the first signal (e.g. to note on disk that a stop
        #: was asked for, before the ranks may be killed mid-block); errors are ignored
        self.on_signal: Callable[[int], None] | None = None
        self._previous: dict[int, object] = {}
        if threading.current_thread() is threading.main_thread():
            for s in signals:
                self._previous[s] = signal.signal(s, self._handler)

    def _handler(self, signum, frame):
        if not self._signum:  # the first signal is the one reported
            self._signum = int(signum)
            if self.on_signal is not None:
                try:
                    self.on_signal(int(signum))
                except Exception:   # a note, never a reason to fail the run
                    pass

    @property
    def installed(self) -> tuple[int, ...]:
        """The signals this object is handling now."""
        return tuple(self._previous)

    @property
    def signal_received(self) -> int:
        """The first signal this rank received (0: none); rank-local, not collective."""
        return self._signum

    def elapsed(self) -> float:
        """Seconds since ``t_start`` on this rank's clock."""
        return self.clock() - self.t_start

    def reason(self, next_block_s: float = 0.0) -> str | None:
        """Why to stop now, or None; COLLECTIVE, the same answer on every rank.

        ``next_block_s`` is the caller's estimate of the next block's duration (plus the
        checkpoint): the budget is exhausted when elapsed + next_block_s > max_wall_s.
        """
        code = np.zeros(5, dtype=np.int64)
        code[_SIGNAL] = self._signum
        if self.comm.rank == 0:
            if self.stop_file is not None and self.stop_file.exists():
                code[_STOP] = 1
            elapsed = self.elapsed()
            if self.max_wall_s is not None and elapsed + next_block_s > self.max_wall_s:
                code[_WALL] = 1
            code[_ELAPSED] = max(0, round(elapsed))
            code[_NEXT] = max(0, round(next_block_s))
        agreed = np.zeros_like(code)
        self.comm.Allreduce(code, agreed, op=_op_max())
        reasons = []
        if agreed[_SIGNAL]:
            reasons.append(f"signal {_signal_name(int(agreed[_SIGNAL]))}")
        if agreed[_STOP]:
            reasons.append(f"STOP file {self.stop_file}")
        if agreed[_WALL]:
            reasons.append(f"wall-time budget {self.max_wall_s:g} s ({agreed[_ELAPSED]} s "
                           f"elapsed, next block ~{agreed[_NEXT]} s)")
        return "; ".join(reasons) or None

    def close(self, final: bool = False) -> None:
        """Restore the signal handlers that were there before; ``final``: ignore the signals
        instead (the process is about to exit with its results written: a late SIGUSR1, whose
        default action is to terminate, must not turn a finished run into exit 138)."""
        for s, previous in self._previous.items():
            signal.signal(s, signal.SIG_IGN if final else previous)
        self._previous = {}

    def __enter__(self) -> StopControl:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _signal_name(signum: int) -> str:
    try:
        return signal.Signals(signum).name
    except ValueError:
        return str(signum)
