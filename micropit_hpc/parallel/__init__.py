"""Everything that knows about MPI ranks beyond a communicator argument lives in this package."""

from __future__ import annotations

import os

# Environment variables by which launchers announce the number of ranks they started.
LAUNCHER_SIZE_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_STEP_NUM_TASKS")


LAUNCHER_RANK_VARS = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK")


def _from_environment(names: tuple[str, ...]) -> int | None:
    for var in names:
        value = os.environ.get(var, "")
        if value.isdigit():
            return int(value)
    return None


def launcher_size() -> int | None:
    """The number of ranks the launcher says it started, or None outside a launcher."""
    return _from_environment(LAUNCHER_SIZE_VARS)


def launcher_rank() -> int:
    """This process's rank as the launcher announced it (0 outside a launcher), without
    initialising MPI."""
    return _from_environment(LAUNCHER_RANK_VARS) or 0


class SerialComm:
    """A one-rank stand-in for ``MPI.COMM_WORLD`` when mpi4py is not installed."""

    rank = 0
    size = 1

    def bcast(self, obj, root=0):
        return obj

    def allgather(self, obj):
        return [obj]

    def gather(self, obj, root=0):
        return [obj]

    def Barrier(self):
        pass

    def Get_rank(self) -> int:
        return 0

    def Get_size(self) -> int:
        return 1

    def allreduce(self, obj, op=None):
        """The reduction over one rank is the value itself (``op`` is ignored)."""
        return obj

    def Allreduce(self, sendbuf, recvbuf, op=None):
        """Buffer reduction over one rank: a copy of ``sendbuf`` into ``recvbuf``."""
        recvbuf[...] = sendbuf

    def Split(self, color=0, key=0):
        """Every split of one rank is again one rank."""
        return SerialComm()

    def Free(self):
        pass


def world():
    """``MPI.COMM_WORLD``, or a :class:`SerialComm` if mpi4py cannot be imported."""
    try:
        from mpi4py import MPI
    except ImportError:
        return SerialComm()
    return MPI.COMM_WORLD
