"""Synthetic surfaces are the same on every rank and for any slab split (docs/hpc.md §2, §4).

Run under ``mpirun -n 2 ... -m pytest --with-mpi -m mpi``. Each verdict is allgathered before
it is asserted, so a failure on one rank fails every rank instead of hanging the other.
"""

from __future__ import annotations

import numpy as np
import pytest

from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces import gaussian_surface, self_affine_surface, white_noise

UM = 1e-6


def all_ranks_agree(comm, ok: bool) -> bool:
    return all(comm.allgather(bool(ok)))


@pytest.mark.mpi(min_size=2)
def test_every_rank_builds_the_same_surfaces_bitwise():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    g = Grid(96, 80, 96 * UM, 80 * UM)
    mine = [gaussian_surface(g, 0.3 * UM, 4 * UM, 40 * UM, seed=2018).heights,
            gaussian_surface(g, 0.3 * UM, 4 * UM, np.inf, seed=2018, acf="gaussian").heights,
            self_affine_surface(g, 0.2 * UM, 0.8, 48 * UM, 3 * UM, seed=2018).heights]
    ok = all(np.array_equal(a.view(np.uint64), b.view(np.uint64))  # bit patterns
             for theirs in comm.allgather(mine) for a, b in zip(mine, theirs, strict=True))
    assert all_ranks_agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("nx,split", [(64, "even"), (33, "even"), (5, "even"), (6, "rank0")])
def test_slabs_of_white_noise_gather_to_the_serial_noise(nx, split):
    """Each rank generates only its contiguous rows ("rank0": the other ranks own none)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    g = Grid(nx, 7, 1.0, 1.0)
    if split == "even":
        bounds = np.linspace(0, nx, comm.size + 1).astype(int)
        rows = range(bounds[comm.rank], bounds[comm.rank + 1])
    else:
        rows = range(nx) if comm.rank == 0 else range(nx, nx)
    slab = white_noise(g, 77, rows=rows, spawn_key=(5,))
    full = np.concatenate(comm.allgather(slab), axis=0)
    ok = slab.shape == (len(rows), 7) and np.array_equal(full, white_noise(g, 77, spawn_key=(5,)))
    assert all_ranks_agree(comm, ok)
