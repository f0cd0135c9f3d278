"""The parallel checkpoint contract (docs/hpc.md §3): collective writes where ranks have unequal
(or no) work, items split over ranks, reads on another layout, and a writer killed mid-file.

Run under ``mpirun -n 2 ... -m pytest --with-mpi -m mpi``. Each verdict is allgathered before
it is asserted, so a failure on one rank fails every rank instead of hanging the other.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from micropit_hpc.errors import MicropitError
from micropit_hpc.io.checkpoint import (
    FieldSpec,
    Piece,
    find_latest,
    read_checkpoint,
    write_checkpoint,
)

ROOT = Path(__file__).resolve().parents[1]


def all_ranks_agree(comm, ok: bool) -> bool:
    return all(comm.allgather(bool(ok)))


def value(item, shape, field=0):
    return np.arange(np.prod(shape), dtype=float).reshape(shape) + 1000.0 * item + 0.5 * field


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_a_rank_with_no_pieces_does_not_deadlock(shared_dir):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    fields = [FieldSpec("a", (4, 3), "f8"), FieldSpec("b/c", (2,), "i4")]
    # Rank 0 writes everything (3 pieces of "a", 1 of "b/c"); the others write nothing.
    pieces = ([Piece(i, "a", value(i, (4, 3))) for i in range(3)]
              + [Piece(1, "b/c", np.array([7, 8], dtype=np.int32))] if comm.rank == 0 else [])
    path = write_checkpoint(shared_dir, comm, 1, 3, fields, pieces, {"note": "rank 0 only"})
    attrs, data = read_checkpoint(path, comm, [(i, "a", None) for i in range(3)]
                                  + [(1, "b/c", None), (0, "b/c", None)])
    ok = (path == shared_dir / "ckpt_000001.h5" and attrs["ranks"] == comm.size
          and attrs["note"] == "rank 0 only"
          and all(np.array_equal(data[(i, "a")], value(i, (4, 3))) for i in range(3))
          and data[(1, "b/c")].tolist() == [7, 8] and data[(0, "b/c")].tolist() == [0, 0])
    assert all_ranks_agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_ranks_write_disjoint_regions_of_one_item(shared_dir):
    """A patch split over ranks along its first axis (uneven slabs; rank 0 also has an empty
    slab), plus a field only the last rank writes, with several pieces."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    shape = (7, 5, 2)
    patch = value(2, shape)
    bounds = np.linspace(0, 7, comm.size + 1).astype(int)  # 2 ranks: rows 0:3 and 3:7
    lo, hi = bounds[comm.rank], bounds[comm.rank + 1]
    pieces = [Piece(2, "stress", patch[lo:hi], (slice(lo, hi),))]
    if comm.rank == 0:
        pieces.append(Piece(2, "stress", patch[7:], (slice(7, None),)))  # an empty slab
    if comm.rank == comm.size - 1:
        pieces += [Piece(i, "cycles", np.int64(i * 11)) for i in range(3)]
    # Item 0: every rank writes every size-th row (strided regions).
    pieces.append(Piece(0, "stress", value(0, shape)[comm.rank::comm.size],
                        (slice(comm.rank, None, comm.size),)))
    fields = [FieldSpec("stress", shape, "f8"), FieldSpec("cycles", (), "i8")]
    path = write_checkpoint(shared_dir, comm, 4, 3, fields, pieces, {})
    _, data = read_checkpoint(path, comm, [(2, "stress", None), (1, "stress", None),
                                           (0, "stress", None)]
                              + [(i, "cycles", None) for i in range(3)])
    ok = (np.array_equal(data[(2, "stress")], patch) and not data[(1, "stress")].any()
          and np.array_equal(data[(0, "stress")], value(0, shape))
          and [int(data[(i, "cycles")]) for i in range(3)] == [0, 11, 22])
    assert all_ranks_agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_restart_reads_other_items_on_each_rank(shared_dir):
    """Written round robin, read back with a different assignment and a region: a restart on
    another layout is just other selections."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    n_items, shape = 5, (6, 4)
    fields = [FieldSpec("h", shape, "f8"), FieldSpec("w", shape, "f4")]
    pieces = [Piece(i, name, value(i, shape, k).astype(dtype))
              for i in range(comm.rank, n_items, comm.size)
              for k, (name, dtype) in enumerate((("h", "f8"), ("w", "f4")))]
    for block in (1, 2):
        write_checkpoint(shared_dir, comm, block, n_items, fields, pieces,
                         {"cycles_done": block * 100}, keep=1)
    latest = find_latest(shared_dir, comm)
    mine = list(range(n_items - 1 - comm.rank, -1, -comm.size))  # another layout
    attrs, data = read_checkpoint(latest, comm, [(i, "h", None) for i in mine]
                                  + [(mine[0], "w", (slice(2, 5), slice(1, None)))])
    ok = (latest == shared_dir / "ckpt_000002.h5" and attrs["cycles_done"] == 200
          and sorted(os.listdir(shared_dir)) == ["LATEST", "ckpt_000002.h5"]
          and all(np.array_equal(data[(i, "h")], value(i, shape)) for i in mine)
          and np.array_equal(data[(mine[0], "w")],
                             value(mine[0], shape, 1).astype("f4")[2:5, 1:]))
    assert all_ranks_agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_a_problem_on_one_rank_is_an_error_on_every_rank(shared_dir):
    """A bad piece or a differing argument on one rank raises everywhere instead of leaving
    the other ranks waiting in a collective call; nothing is written."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    fields = [FieldSpec("a", (3,), "f8")]
    bad = [Piece(0, "a", np.zeros(4))] if comm.rank == 1 else []
    with pytest.raises(MicropitError, match="rank 1: field 'a', item 0: data of shape"):
        write_checkpoint(shared_dir, comm, 1, 2, fields, bad, {})
    with pytest.raises(MicropitError, match="rank 1: arguments differ from rank 0"):
        write_checkpoint(shared_dir, comm, 1 + (comm.rank == 1), 2, fields, [], {})
    comm.Barrier()
    assert all_ranks_agree(comm, os.listdir(shared_dir) == [])


CRASH_CHILD = """
import os, signal, sys
import numpy as np
from mpi4py import MPI
from micropit_hpc.io import checkpoint as ck

comm = MPI.COMM_WORLD
directory, stage = sys.argv[1], sys.argv[2]
fields = [ck.FieldSpec("damage", (3, 2), "f8")]
def pieces(block):
    return [ck.Piece(i, "damage", np.full((3, 2), 10.0 * block + i))
            for i in range(comm.rank, 4, comm.size)]
ck.write_checkpoint(directory, comm, 1, 4, fields, pieces(1), {"cycles_done": 1})

def die(name, path):
    if name == stage and comm.rank == 0:
        os.kill(os.getpid(), signal.SIGKILL)
ck._at_stage = die
ck.write_checkpoint(directory, comm, 2, 4, fields, pieces(2), {"cycles_done": 2})
print("not killed", flush=True)
"""


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(120)
@pytest.mark.parametrize("stage", ["data", "closed"])
def test_a_job_killed_while_writing_leaves_the_previous_checkpoint(shared_dir, stage):
    """Rank 0 launches a 2-rank job (its own mpirun) that writes block 1 and is SIGKILLed in
    the middle of block 2; then every rank checks what is left and writes block 2 again."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    verdict = ""
    if comm.rank == 0:
        script = shared_dir / "child.py"
        script.write_text(textwrap.dedent(CRASH_CHILD))
        # The nested job must not believe it belongs to this one.
        env = {k: v for k, v in os.environ.items()
               if not k.startswith(("OMPI_", "PMIX_", "OPAL_", "ORTE_", "PMI_"))}
        env.update(PYTHONPATH=str(ROOT), H5PY_ALWAYS_USE_MPI="1",
                   OMPI_MCA_rmaps_base_oversubscribe="1")
        if os.getuid() == 0:
            env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        mpirun = shutil.which("mpirun")
        try:
            run = subprocess.run([mpirun, "-n", "2", sys.executable, str(script),
                                  str(shared_dir / "ck"), stage],
                                 env=env, capture_output=True, text=True, timeout=90)
            if run.returncode == 0 or "not killed" in run.stdout:
                verdict = f"child was not killed: rc {run.returncode}\n{run.stderr[-2000:]}"
        except subprocess.TimeoutExpired:
            verdict = "child job hung after its rank 0 was killed"
    verdict = comm.bcast(verdict, root=0)
    assert verdict == ""
    directory = shared_dir / "ck"
    latest = find_latest(directory, comm)
    attrs, data = read_checkpoint(latest, comm, [(comm.rank, "damage", None)])
    ok = (latest == directory / "ckpt_000001.h5" and attrs["cycles_done"] == 1
          and (directory / "LATEST").read_text().strip() == "ckpt_000001.h5"
          and (directory / "ckpt_000002.h5.tmp").exists()
          and np.array_equal(data[(comm.rank, "damage")], np.full((3, 2), 10.0 + comm.rank)))
    comm.Barrier()
    # The restarted job writes block 2 over the leftover temporary file.
    fields = [FieldSpec("damage", (3, 2), "f8")]
    path = write_checkpoint(directory, comm, 2, 4, fields,
                            [Piece(comm.rank, "damage", np.full((3, 2), 20.0 + comm.rank))],
                            {"cycles_done": 2})
    attrs, data = read_checkpoint(find_latest(directory, comm), comm, [(1, "damage", None)])
    ok = (ok and path == directory / "ckpt_000002.h5" and attrs["cycles_done"] == 2
          and not (directory / "ckpt_000002.h5.tmp").exists()
          and np.array_equal(data[(1, "damage")], np.full((3, 2), 21.0)))
    assert all_ranks_agree(comm, ok)
