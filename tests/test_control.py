"""Stopping at a block boundary: signals, the STOP file and the wall-time budget, agreed by
every rank (docs/hpc.md §3, "Long jobs")."""

from __future__ import annotations

import os
import signal
import tempfile
import threading
from pathlib import Path

import pytest

from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.control import StopControl


class FakeClock:
    def __init__(self, t=0.0):
        self.t = t

    def __call__(self):
        return self.t


def test_the_first_signal_is_passed_to_on_signal_once():
    """The hook rank 0 uses to note a stop request on disk at once (a job script then knows the
    run was asked to stop even if the ranks are killed before the next boundary)."""
    seen = []
    with StopControl(SerialComm()) as ctl:
        ctl.on_signal = seen.append
        os.kill(os.getpid(), signal.SIGUSR1)
        os.kill(os.getpid(), signal.SIGTERM)
        ctl.on_signal = lambda s: 1 / 0            # a failing hook is ignored
    assert seen == [signal.SIGUSR1]


@pytest.mark.parametrize("sig", [signal.SIGUSR1, signal.SIGTERM])
def test_a_signal_is_reported_at_the_next_boundary(sig):
    with StopControl(SerialComm()) as ctl:
        assert ctl.reason() is None
        os.kill(os.getpid(), sig)
        assert ctl.signal_received == sig
        assert ctl.reason() == f"signal {sig.name}"
        os.kill(os.getpid(), signal.SIGUSR1)  # the first signal is the one reported
        assert ctl.reason() == f"signal {sig.name}"


def test_previous_handlers_come_back():
    seen = []
    before = signal.signal(signal.SIGUSR1, lambda s, f: seen.append(s))
    try:
        ctl = StopControl(SerialComm(), signals=(signal.SIGUSR1,))
        assert ctl.installed == (signal.SIGUSR1,)
        os.kill(os.getpid(), signal.SIGUSR1)
        assert seen == [] and ctl.reason() == "signal SIGUSR1"
        ctl.close()
        assert ctl.installed == ()
        os.kill(os.getpid(), signal.SIGUSR1)
        assert seen == [signal.SIGUSR1]
    finally:
        signal.signal(signal.SIGUSR1, before)


def test_no_handlers_outside_the_main_thread():
    out = {}
    previous = signal.getsignal(signal.SIGUSR1)

    def make():
        out["ctl"] = StopControl(SerialComm())

    t = threading.Thread(target=make)
    t.start()
    t.join()
    assert out["ctl"].installed == ()
    assert signal.getsignal(signal.SIGUSR1) is previous
    assert out["ctl"].reason() is None


def test_stop_file(tmp_path):
    stop = tmp_path / "STOP"
    with StopControl(SerialComm(), stop_file=stop, signals=()) as ctl:
        assert ctl.reason() is None
        stop.touch()
        assert ctl.reason() == f"STOP file {stop}"
        stop.unlink()
        assert ctl.reason() is None


def test_wall_time_budget_counts_the_next_block():
    clock = FakeClock(100.0)
    with StopControl(SerialComm(), max_wall_s=3600, t_start=100.0, clock=clock,
                     signals=()) as ctl:
        clock.t = 3100.0
        assert ctl.elapsed() == 3000.0
        assert ctl.reason(next_block_s=599.0) is None
        assert ctl.reason(next_block_s=601.0) == ("wall-time budget 3600 s (3000 s elapsed, "
                                                  "next block ~601 s)")
        clock.t = 3701.0
        assert ctl.reason().startswith("wall-time budget 3600 s (3601 s elapsed")
    with StopControl(SerialComm(), max_wall_s=None, clock=clock, signals=()) as ctl:
        clock.t = 1e9
        assert ctl.reason(next_block_s=1e9) is None


def test_every_reason_is_reported(tmp_path):
    stop = tmp_path / "STOP"
    stop.touch()
    clock = FakeClock(0.0)
    with StopControl(SerialComm(), stop, max_wall_s=10, clock=clock,
                     signals=(signal.SIGUSR1,)) as ctl:
        os.kill(os.getpid(), signal.SIGUSR1)
        clock.t = 11
        assert ctl.reason() == (f"signal SIGUSR1; STOP file {stop}; wall-time budget 10 s "
                                "(11 s elapsed, next block ~0 s)")


def test_a_budget_must_be_positive():
    with pytest.raises(ValueError, match="positive"):
        StopControl(SerialComm(), max_wall_s=0, signals=())


def all_ranks_agree(comm, ok: bool) -> bool:
    return all(comm.allgather(bool(ok)))


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_a_signal_on_one_rank_stops_every_rank():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    with StopControl(comm) as ctl:
        first = ctl.reason()
        comm.Barrier()
        if comm.rank == 1:
            os.kill(os.getpid(), signal.SIGUSR1)
        second = ctl.reason()
    answers = comm.allgather((first, second))
    assert all_ranks_agree(comm, all(a == (None, "signal SIGUSR1") for a in answers))


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_rank_0_decides_the_stop_file_and_the_budget():
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    name = comm.bcast(tempfile.mkdtemp(prefix="micropit-stop-") if comm.rank == 0 else None,
                      root=0)
    stop = Path(name) / "STOP"
    # Only rank 1's clock says the budget is spent: rank 0's clock decides, so no stop.
    clock = FakeClock(50.0 if comm.rank == 0 else 5000.0)
    with StopControl(comm, stop, max_wall_s=100, t_start=0.0, clock=clock, signals=()) as ctl:
        calm = ctl.reason(next_block_s=10)
        late = ctl.reason(next_block_s=60 if comm.rank == 0 else 0)
        if comm.rank == 0:
            stop.touch()
        try:
            stopped = ctl.reason(next_block_s=10)
        finally:
            comm.Barrier()
            if comm.rank == 0:
                stop.unlink()
                stop.parent.rmdir()
    answers = comm.allgather((calm, late, stopped))
    want = (None, "wall-time budget 100 s (50 s elapsed, next block ~60 s)", f"STOP file {stop}")
    assert all_ranks_agree(comm, all(a == want for a in answers))
