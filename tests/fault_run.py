"""``python tests/fault_run.py WHERE RANK micropit-args...``: run the ``micropit`` command with a
fault injected on one rank (tests/test_faults.py). Test code only: the package has no fault hooks
beyond the checkpoint writer's ``_at_stage``.

WHERE:
* ``restart``: rank RANK fails right after reading its state from the checkpoint;
* ``checkpoint``: rank RANK fails inside the collective checkpoint write (after its data);
* ``killckpt``: rank RANK is SIGKILLed inside the second checkpoint write (after its data);
* ``results``: rank RANK fails while the results are written (rank 0 writes them);
* ``internal``: rank RANK raises a KeyError (a bug) in the middle of block 1;
* ``collective``: rank RANK alone raises an error marked collective (a wrong marking: the
  safety net must still end the job);
* ``none``: no fault.
"""

from __future__ import annotations

import sys


def main() -> int:
    where, rank = sys.argv[1], int(sys.argv[2])
    argv = sys.argv[3:]
    from mpi4py import MPI

    import micropit_hpc.io.checkpoint as ck
    import micropit_hpc.io.results as res
    import micropit_hpc.runner as runner
    import micropit_hpc.study as study
    from micropit_hpc.cli import main as cli_main
    from micropit_hpc.errors import MicropitError

    me = MPI.COMM_WORLD.rank
    if me == rank and where == "restart":
        read = runner._read_state

        def bad_read(path, st):
            read(path, st)
            raise MicropitError(f"injected fault: rank {me} cannot use its state from {path}")
        runner._read_state = bad_read
    elif me == rank and where == "checkpoint":
        def bad_stage(stage, path):
            if stage == "data":
                raise MicropitError(f"injected fault: rank {me} failed writing {path}")
        ck._at_stage = bad_stage
    elif me == rank and where == "killckpt":
        import os
        import signal
        writes = []

        def die(stage, path):
            if stage == "data":
                writes.append(path)
                if len(writes) == 2:
                    os.kill(os.getpid(), signal.SIGKILL)
        ck._at_stage = die
    elif me == rank and where == "results":
        def bad_results(path, *a, **k):
            raise MicropitError(f"injected fault: cannot write {path}")
        res.write_results = bad_results
    elif me == rank and where == "collective":
        from micropit_hpc.errors import collective

        def bad_pieces(*a, **k):
            raise collective(MicropitError("injected fault: a collective error on one rank"))
        runner._pieces = bad_pieces
    elif me == rank and where == "internal":
        run_block = study.ItemRun.run_block

        def bad_block(self, *a, **k):
            run_block(self, *a, **k)
            raise KeyError("records")
        study.ItemRun.run_block = bad_block
    return cli_main(argv)


if __name__ == "__main__":
    sys.exit(main())
