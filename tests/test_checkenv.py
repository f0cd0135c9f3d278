"""micropit check-env: serial behaviour here, the parallel checks under mpirun -n 2."""

from __future__ import annotations

import pytest
from helpers import SCENES

from micropit_hpc import checkenv
from micropit_hpc.checkenv import OK, PROBLEM, Check, format_report


def test_problems_are_listed_by_name_and_rank():
    per_rank = [[Check("numpy", OK, "1.24.2"), Check("h5py", OK, "3.7")],
                [Check("numpy", OK, "1.24.2"), Check("h5py", PROBLEM, "serial build", "fix it")]]
    text, problems = format_report(per_rank)
    assert problems == ["h5py (rank 1): serial build -- fix it"]
    assert "1 problem(s)" in text and "environment OK" not in text


@pytest.mark.parametrize("vendor,launcher,same", [
    ("Open MPI", "mpirun (Open MPI) 4.1.4 (/usr/bin/mpirun)", True),
    ("MPICH", "mpirun (Open MPI) 4.1.4 (/usr/bin/mpirun)", False),
    ("Open MPI", "HYDRA build details: (/opt/mpich/bin/mpirun)", False),
    ("MPICH", "HYDRA build details: (/opt/mpich/bin/mpirun)", True),
])
def test_launcher_and_library_families(vendor, launcher, same):
    assert checkenv._same_family(vendor, launcher) is same


def test_launcher_that_started_more_ranks_than_mpi4py_sees(monkeypatch):
    """The singleton trap: the launcher says 2 ranks, mpi4py's MPI sees 1."""
    monkeypatch.setenv("OMPI_COMM_WORLD_SIZE", "2")

    class One:
        rank, size = 0, 1

    ranks = next(c for c in checkenv.check_mpi(One(), None) if c.name == "ranks")
    assert ranks.status == PROBLEM and "launcher started 2" in ranks.detail


def test_serial_environment_passes_and_a_wrong_rank_count_fails(capsys, monkeypatch):
    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "SLURM_STEP_NUM_TASKS"):
        monkeypatch.delenv(var, raising=False)
    assert checkenv.main() == 0, capsys.readouterr().out
    out = capsys.readouterr().out
    for name in ("mpi4py", "ranks", "h5py", "petsc4py", "pyfftw"):
        assert f"  {name}" in out
    assert "collective write by 1 ranks" in out
    assert checkenv.main(expect_ranks=3) == 1
    assert "ranks (rank 0): 1 rank, expected 3" in capsys.readouterr().out


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
def test_parallel_environment_under_mpirun(capsys):
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    checks = {c.name: c for c in checkenv.run_checks(comm, expect_ranks=comm.size)}
    verdict = comm.allgather({n: c.status for n, c in checks.items()})
    assert all(v[n] == OK for v in verdict for n in ("ranks", "h5py", "petsc4py", "pyfftw"))
    assert f"collective write by {comm.size} ranks" in checks["h5py"].detail
    assert checkenv.main(expect_ranks=comm.size + 1) == 1


@pytest.mark.slow
@pytest.mark.mpi(min_size=2)
def test_contact_writes_once_under_mpirun(tmp_path_factory, capsys, monkeypatch):
    from mpi4py import MPI

    from micropit_hpc import report
    from micropit_hpc.cli import main

    writes = []
    real_write = report.write_text_atomic
    monkeypatch.setattr(report, "write_text_atomic",
                        lambda path, text: (writes.append(path), real_write(path, text)))
    comm = MPI.COMM_WORLD
    target = comm.bcast(str(tmp_path_factory.mktemp("c") / "c.csv") if comm.rank == 0 else None)
    assert main(["contact", str(SCENES / "paper_mpr.toml"), "--csv", target]) == 0
    out = capsys.readouterr().out
    lines = comm.allgather(out.count("\n"))
    assert lines[0] > 3 and all(n == 0 for n in lines[1:])  # only rank 0 prints
    assert comm.allgather(len(writes)) == [1] + [0] * (comm.size - 1)  # and writes
    comm.Barrier()
    with open(target) as fh:
        assert fh.read().startswith("position,roll_angle_deg")
