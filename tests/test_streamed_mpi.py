"""The streamed stress history on a slab of several ranks (docs/performance.md "Streamed
stresses"): every rank takes the same chunks of layers, also when the slabs differ in size.
Over the slabs (``contact_parallel = "slabs"``) τ_DV equals the stacked whole-depth history on
the slab bitwise and the one-rank result on its rows to round-off (the distributed transforms
sum in another order); with the steps shared (``"steps"``: each rank transforms the whole
window for its steps and sends the rows, ``PositionCycle.stress_by_steps``) it equals the
one-rank result on its rows bit for bit.

Run under ``mpirun -n 2 ... -m pytest --with-mpi -m mpi``. Each verdict is allgathered before it
is asserted, so a failure on one rank fails every rank instead of hanging the other.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import SMALL, gear_scene

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.fatigue.dangvan import dang_van
from micropit_hpc.scene import load_scene


def all_ranks_agree(comm, ok: bool) -> bool:
    return all(comm.allgather(bool(ok)))


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("parallel", ["slabs", "steps"])
@pytest.mark.parametrize("process_um", [0.0, 40.0])
def test_streamed_stresses_on_uneven_slabs(tmp_path, parallel, process_um):
    """Also with the stresses averaged over a process area (``fatigue.process_length_um`` of
    3.6 cells here): the transfer is applied to each rank's spectral columns, or to the whole
    window's under "steps", with the same numbers."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    extra = SMALL.replace("n = 32", "n = 33").replace("layers = 4", "layers = 5")
    extra += f"[fatigue]\nprocess_length_um = {process_um}\n"
    study = contact_study(load_scene(gear_scene(tmp_path, extra=extra)))
    cyc = PositionCycle(study, 3, comm=comm, parallel=parallel)
    assert cyc.stress_by_steps == (parallel == "steps")
    assert (cyc.process_transfer(slice(None)) is None) == (process_um == 0.0)
    counts = cyc.slab.counts
    m, ny = cyc.steps, cyc.grid.ny
    # two layers of the smallest slab's history: one of the largest; a per-rank rule would
    # give the ranks different chunks (and mismatched collective transforms)
    cyc.stress_chunk_bytes = 48.0 * m * ny * min(counts) * 2
    sizes = comm.allgather(cyc.chunk_layers())
    ok_sizes = len(set(sizes)) == 1 and (sizes[0] == 1 or min(counts) == max(counts))
    fields, p = [], None
    for j in range(m):
        fields.append(cyc.solve_step(j, p))
        p = fields[-1].pressure
    one = PositionCycle(study, 3)
    ok_slab, ok_one, err = True, True, 0.0
    for body in (1, 2):
        tau, _, _ = cyc._streamed_dang_van(fields, body, False)
        ref = dang_van(np.stack([one.stresses(f, body) for f in fields]),
                       alpha=one.alpha_dv).tau_dv[:, cyc.slab.rows]
        err = max(err, float(np.abs(tau - ref).max() / np.abs(ref).max()))
        if parallel == "steps":
            ok_one &= np.array_equal(tau, ref)
        else:
            hist = np.stack([cyc.stresses(f, body) for f in fields])
            ok_slab &= np.array_equal(tau, dang_van(hist, alpha=cyc.alpha_dv).tau_dv)
    assert all_ranks_agree(comm, ok_sizes), (sizes, counts)
    assert all_ranks_agree(comm, ok_slab)
    assert all_ranks_agree(comm, ok_one), err
    assert all_ranks_agree(comm, err < 1e-12), err
