"""Shared test fixtures (the shared helpers are in tests/helpers.py), and the guard that turns
a rank-local failure into a prompt abort.

Under ``mpirun -n 2 ... --with-mpi``, a failing assertion on one rank while the other waits in a
collective call would hang the run; the hook below prints the failure and aborts every rank.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from helpers import SCENES


@pytest.fixture
def scene_text():
    """The text of a scene in scenes/, by name."""
    return lambda name: (SCENES / f"{name}.toml").read_text()


@pytest.fixture
def shared_dir():
    """A fresh directory every MPI rank sees (rank 0 makes it, the others get its name)."""
    import shutil
    import tempfile

    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    name = tempfile.mkdtemp(prefix="micropit-mpi-") if comm.rank == 0 else None
    path = Path(comm.bcast(name, root=0))
    yield path
    comm.Barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def _mpi_size() -> int:
    if "mpi4py" not in sys.modules:
        return 1
    return sys.modules["mpi4py"].MPI.COMM_WORLD.size


def pytest_runtest_logreport(report):
    if report.failed and _mpi_size() > 1:
        from mpi4py import MPI

        sys.stderr.write(f"\n[rank {MPI.COMM_WORLD.rank}] {report.nodeid} failed:\n"
                         f"{report.longreprtext}\n")
        sys.stderr.flush()
        MPI.COMM_WORLD.Abort(1)


# Debian's h5py picks its MPI build only when asked (docs/install.md, trap 2).
os.environ.setdefault("H5PY_ALWAYS_USE_MPI", "1")
