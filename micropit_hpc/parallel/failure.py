"""Ending the whole job when one rank fails (docs/jobs.md, exit codes and collective failure).

A rank that raises while the others wait for it in a collective call (a gather after a block,
a collective HDF5 write or close) must not leave them spinning: it prints its one-line message
and calls ``MPI_Abort``, which ends every rank of the job within seconds. Errors that every rank
raises alike (``MicropitError.collective``) are reported once by rank 0 instead
(:func:`micropit_hpc.cli.main`).
"""

from __future__ import annotations

import sys
import traceback
from collections.abc import Iterator
from contextlib import contextmanager

from micropit_hpc.errors import MicropitError


def say(line: str) -> None:
    """Write ``line`` and its newline to stderr in ONE write: under ``mpirun`` the ranks'
    streams are merged, and a line written in pieces (print writes the newline separately on
    an unbuffered stream) can end up joined with another rank's line."""
    sys.stderr.write(line + "\n")
    sys.stderr.flush()


def one_line(e: BaseException) -> tuple[str, int]:
    """(the error as one line, the exit code): 2 for a user error, 1 for a bug."""
    code = 2 if isinstance(e, MicropitError) else 1
    if isinstance(e, MemoryError):
        text = ("out of memory (MemoryError): the run needs more memory than this machine or "
                "job gives it; use a smaller window.n, fewer stress.layers, fewer positions "
                "per job, or more ranks per item (--ranks-per-item)")
    elif isinstance(e, KeyboardInterrupt):
        text, code = "interrupted (Ctrl-C)", 130
    elif isinstance(e, MicropitError):
        text = str(e)
    else:
        text = f"internal error: {type(e).__name__}: {e}"
    return " ".join(text.split()), code


def is_bug(e: BaseException) -> bool:
    """True for an exception that is neither a user error nor memory nor Ctrl-C."""
    return not isinstance(e, MicropitError | MemoryError | KeyboardInterrupt)


#: Seconds a non-root rank of a group waits before reporting an error of its group's item
#: itself (the root, which met it too, normally reports it and aborts the job first).
GROUP_MEMBER_WAIT_S = 5.0


def abort_job(e: BaseException, comm, debug: bool = False) -> None:
    """Print ``e`` on this rank (its traceback too if it is a bug or ``debug``) and end every
    rank of ``comm``'s job with ``MPI_Abort``. Does not return. An error marked
    ``group_member`` (a non-root rank of a work item's group) is reported only if the group
    root has not ended the job within :data:`GROUP_MEMBER_WAIT_S`: so the message appears
    once."""
    import time

    if getattr(e, "group_member", False):
        time.sleep(GROUP_MEMBER_WAIT_S)
    text, code = one_line(e)
    if debug or is_bug(e):
        traceback.print_exception(e)
    say(f"micropit: error: rank {comm.Get_rank()} of {comm.Get_size()}: {text}")
    comm.Abort(code)


@contextmanager
def abort_on_error(comm, active: bool = True) -> Iterator[None]:
    """Inside, any exception on one rank of a multi-rank ``comm`` aborts the job at once
    (:func:`abort_job`); use it around collective work that cannot be unwound on one rank
    alone (a collective HDF5 write: closing the file is itself collective)."""
    try:
        yield
    except BaseException as e:
        if active and comm is not None and comm.Get_size() > 1:
            abort_job(e, comm)
        raise
