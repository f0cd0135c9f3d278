"""Root computes, every rank learns the answer or the error (docs/hpc.md §2, §4).

Much of what a run decides is decided once, on the root of a communicator (scan the checkpoints,
hash the measured maps, lock the output folder, name the run), and every
rank must then go on with the same value, or leave through the same error at the same point:
a rank that raised while the others wait in the broadcast would hang the job. The two helpers
here are that pattern, written once.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from micropit_hpc.errors import MicropitError, collective

__all__ = ["from_root", "raise_agreed"]

T = TypeVar("T")


def from_root(comm, compute: Callable[[], T],
              catch: type[BaseException] | tuple[type[BaseException], ...] = MicropitError,
              world: bool = False) -> T:
    """``compute()`` on rank 0 of ``comm``, its value on every rank (collective).

    An exception of a type in ``catch`` raised by ``compute`` on rank 0 is raised on every rank
    instead (the same exception, sent with the broadcast); any other exception is a bug and
    ends the job (:mod:`micropit_hpc.parallel.failure`). ``world``: ``comm`` holds every rank
    of the job, so the error is marked :func:`~micropit_hpc.errors.collective` (reported once
    by rank 0); within a group of ranks it is left rank-local. One rank (or ``comm`` None)
    computes directly.
    """
    value, error = None, None
    if comm is None or comm.size == 1:
        try:
            return compute()
        except catch as e:
            if world and isinstance(e, MicropitError):
                collective(e)
            raise
    if comm.rank == 0:
        try:
            value = compute()
        except catch as e:
            error = e
    value, error = comm.bcast((value, error), root=0)
    if error is not None:
        if world and isinstance(error, MicropitError):
            collective(error)
        raise error
    return value


def raise_agreed(comm, problem: str | None,
                 error: Callable[[str], MicropitError] = MicropitError) -> None:
    """Rank 0's verdict on every rank of ``comm`` (collective, ``comm`` the whole job): when
    rank 0 found a ``problem`` (a one-line message), every rank raises ``error(problem)``,
    marked collective; the other ranks' ``problem`` is ignored."""
    if comm is not None and comm.size > 1:
        problem = comm.bcast(problem, root=0)
    if problem:
        raise collective(error(problem))
