"""The ``micropit`` command (also ``python -m micropit_hpc``). Thin: parse, call, report.

Errors the user can fix (bad scene files, a broken environment) are printed as one line
``micropit: error: ...`` with exit code 2 and no traceback, unless ``--debug`` is given.
"""

from __future__ import annotations

import argparse
import math
import sys

from micropit_hpc import __version__
from micropit_hpc.errors import MicropitError, collective
from micropit_hpc.parallel import launcher_rank

EXIT_USER_ERROR = 2


def _warn_scene(scene) -> None:
    """The scene's plausibility warnings on stderr (rank 0 only: the caller checks)."""
    for w in scene.warnings:
        print(f"micropit: warning: {w}", file=sys.stderr, flush=True)


def _cmd_contact(args: argparse.Namespace) -> int:
    from micropit_hpc.conditions import contact_study
    from micropit_hpc.parallel import world
    from micropit_hpc.report import contact_csv, path_summary, write_text_atomic
    from micropit_hpc.scene import load_scene

    comm = world()
    study = contact_study(load_scene(args.scene))
    if comm.rank == 0:
        _warn_scene(study.scene)
        table = contact_csv(study)
        print("\n".join("# " + line for line in path_summary(study)))
        print(table, end="", flush=True)
        if args.csv:
            try:
                write_text_atomic(args.csv, table)
            except OSError as e:
                raise MicropitError(f"cannot write --csv {args.csv}: {e.strerror}") from None
            print(f"# wrote {args.csv}", flush=True)
    return 0


def _cmd_snapshot(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from micropit_hpc.cycle import PositionCycle
    from micropit_hpc.io.snapshot import write_snapshot
    from micropit_hpc.parallel import world
    from micropit_hpc.plan import make_plan
    from micropit_hpc.plots import snapshot_figure
    from micropit_hpc.scene import load_scene

    comm = world()
    scene = load_scene(args.scene)
    if comm.rank != 0:      # one step of one position is a one-rank job: the others wait
        return 0
    t0 = time.perf_counter()
    plan = make_plan(scene, life=False)
    cycle = PositionCycle(plan.study, args.position, window=plan.window)
    if args.step is None:
        args.step = (cycle.steps + 1) // 2
    if args.step > cycle.steps:
        raise MicropitError(f"--step {args.step}: the cycle has steps 1 to {cycle.steps} "
                            f"(window.steps = {scene.window.steps} in {scene.source}, raised "
                            "by the kinematics where it is: docs/model.md §4)")
    step = args.step - 1
    fields = cycle.solve_step(step)
    t1 = time.perf_counter()
    stresses = {i: cycle.stresses(fields, i) for i in (1, 2)}
    t2 = time.perf_counter()
    out = Path(args.out)
    try:
        h5 = write_snapshot(out / "snapshot.h5", cycle, fields, stresses)
        png = snapshot_figure(out / "snapshot.png", cycle, fields, stresses)
    except OSError as e:
        raise MicropitError(f"cannot write to --out {out}: {e.strerror or e}") from None
    c, g = cycle.cond, cycle.grid
    print(f"# {scene.name}: position {args.position} (S = {c.S:.4g}, p0 = {c.p0 / 1e9:.4g} GPa, "
          f"Λ = {c.Lambda:.3g}), step {args.step}/{cycle.steps}: x_c = {fields.x_c * 1e6:.2f} µm, "
          f"p̄ = {fields.p_mean / 1e9:.4g} GPa")
    print(f"# level {fields.level}, grid {g.nx} x {g.ny} over {g.lx * 1e6:.1f} x "
          f"{g.ly * 1e6:.1f} µm, {len(cycle.z)} layers to {cycle.z[-1] * 1e6:.2f} µm")
    print(f"# solid-load fraction φ = {fields.phi:.4g}, solid contact "
          f"{100 * fields.solid.mean():.2f} % of the window, max pressure "
          f"{fields.pressure.max() / 1e9:.4g} GPa, contact solve {t1 - t0:.2f} s, stresses "
          f"{t2 - t1:.2f} s")
    print(f"# wrote {h5} and {png}", flush=True)
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from micropit_hpc.parallel import world
    from micropit_hpc.parallel.control import StopControl
    from micropit_hpc.parallel.failure import say
    from micropit_hpc.parallel.petsc import init_petsc

    comm = world()
    rank0 = comm.rank == 0
    t0 = time.perf_counter()

    def log(msg: str) -> None:    # every note; --quiet silences the progress lines only
        if rank0:
            say(f"# {msg}")

    # From here on SIGUSR1/SIGTERM are noted, never fatal, until the results are written; a
    # process started as the `micropit` command then ignores them until it exits.
    control = StopControl(comm, None if args.stop_file is None else Path(args.stop_file),
                          _default_budget(args.max_wall, log))
    try:
        init_petsc(args.petsc_options)
        return _run(args, comm, control, log, t0)
    finally:
        control.close(final=args.process_entry)


def _default_budget(max_wall: float | None, log) -> float | None:
    """--max-wall, or by default what is left of a Slurm job (SLURM_JOB_END_TIME) less
    :data:`BUDGET_RESERVE_S` for the last checkpoint, the results and the shutdown."""
    import os
    import time

    if max_wall is not None:
        return max_wall
    end = os.environ.get("SLURM_JOB_END_TIME", "")
    if end.isdigit():
        left = int(end) - time.time() - BUDGET_RESERVE_S
        if left > 0:
            log(f"wall-time budget {left:.0f} s: the Slurm job ends at {end} "
                f"(SLURM_JOB_END_TIME), less {BUDGET_RESERVE_S:g} s kept for the shutdown")
            return left
    return None


#: Seconds kept free at the end of a Slurm job's time by the default wall-time budget.
BUDGET_RESERVE_S = 120.0


def _int_option(name: str, default: int) -> int:
    """A positive whole-number PETSc-style option ``-name``, or a one-line error."""
    from micropit_hpc.parallel.petsc import option

    raw = option(name, None, str)
    if raw is None:
        return default
    text = str(raw).strip()
    if not text.isdigit() or int(text) < 1:
        raise collective(MicropitError(f"-{name} {text}: expected a whole number ≥ 1"))
    return int(text)


def _run(args, comm, control, log, t0) -> int:
    from pathlib import Path

    from micropit_hpc import estimate
    from micropit_hpc.io import outdir
    from micropit_hpc.parallel.control import EXIT_CHECKPOINTED
    from micropit_hpc.parallel.petsc import options_left_warning
    from micropit_hpc.plan import life_blocks, make_plan
    from micropit_hpc.runner import RunOptions
    from micropit_hpc.scene import load_scene

    if args.force and not args.restart:
        raise collective(MicropitError("--force only applies with --restart (it accepts a "
                                       "checkpoint written for another scene)"))
    if args.overwrite and args.restart:
        raise collective(MicropitError("--overwrite deletes the checkpoints that --restart "
                                       "would continue from: give one of them"))
    scene = load_scene(args.scene)
    out = Path(args.out)
    opts = RunOptions(
        out=out, positions=None if args.position is None else tuple(args.position),
        ranks_per_item=args.ranks_per_item, restart=args.restart, force=args.force,
        max_wall_s=control.max_wall_s, stop_file=control.stop_file,
        keep=_int_option("micropit_checkpoint_keep", 3),
        checkpoint_every=_int_option("micropit_checkpoint_every", 1), balance=args.balance)
    n_blocks = life_blocks(scene)
    # the memory check before anything is allocated, then with the items' time steps
    estimate.check(scene, comm, args.ranks_per_item, opts.positions, n_blocks, log,
                   ignore_memory=args.ignore_memory_estimate)
    plan = make_plan(scene, opts.positions)     # every check, on every rank alike
    estimate.check(scene, comm, args.ranks_per_item, opts.positions, n_blocks, log,
                   ignore_memory=args.ignore_memory_estimate, plan=plan)
    lock = outdir.prepare(out, comm, restart=args.restart, overwrite=args.overwrite, log=log)
    if lock is not None:    # rank 0 notes a stop signal on disk at once (outdir.EXIT_RECORD)
        if control.signal_received:
            outdir.write_exit_record(out, f"signal {control.signal_received}")
        control.on_signal = lambda signum: outdir.write_exit_record(out, f"signal {signum}")
    try:
        status = _run_locked(args, comm, control, log, t0, plan, opts)
        code = EXIT_CHECKPOINTED if status == "stopped" else 0
        if lock is not None:        # rank 0: the verdict for a job script (outdir.EXIT_RECORD)
            try:
                outdir.write_exit_record(out, code)
            except OSError as e:    # the run itself is complete: say so, do not fail it
                log(f"warning: cannot write {out / outdir.EXIT_RECORD}: {e.strerror or e} "
                    "(a job script then trusts the launcher's exit code)")
    finally:
        control.on_signal = None
        if lock is not None:
            lock.release()
    options_left_warning(comm)
    return code


def _run_locked(args, comm, control, log, t0, plan, opts) -> str:
    """The run itself, in a locked output folder, with its handlers attached (progress, the
    model's-range warnings, the results); returns "done" or "stopped"."""
    from micropit_hpc.io.results import ResultsHandler
    from micropit_hpc.progress import ProgressHandler
    from micropit_hpc.regime import RangeWarnings
    from micropit_hpc.runner import run_study

    scene, n_blocks = plan.scene, plan.blocks
    last = plan.block_cycles(n_blocks)
    shorter = (f", the last of {last / 1e6:g} M" if last != scene.life.block else "")
    for w in (*scene.warnings, *plan.warnings):
        log(f"warning: {w}")
    if scene.lubricant.derived:
        log(scene.lubricant.derived)
    for line in plan.method_b.lines():
        log(line)
    log(f"{scene.name}: {scene.source}, {comm.size} ranks, {args.ranks_per_item} per item "
        f"({args.balance} balance), "
        f"{n_blocks} blocks of {scene.life.block / 1e6:g} M cycles{shorter} to "
        f"{scene.life.cycles / 1e6:g} M")
    handlers = (RangeWarnings(scene.life, log),
                ProgressHandler(comm.rank == 0, args.quiet),
                ResultsHandler(opts.out, {"ranks": comm.size,
                                          "ranks_per_item": args.ranks_per_item}, t0, log))
    outcome = run_study(scene, opts, comm, log, handlers, control=control, plan=plan)
    if outcome.status == "done" and control.signal_received:
        log(f"signal {control.signal_received} arrived after the last block; the results are "
            "complete")
    return outcome.status


def _out_dir(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder name, got an empty one (a run "
                                         "never writes into the current folder by accident; "
                                         "give --out . for that)")
    return text


def _wall_time(text: str) -> float:
    """Seconds from ``S``, ``M:S``, ``H:M:S`` or ``D-H:M:S`` (Slurm's forms); errors quote the
    value as given."""
    given = text
    if text.strip().startswith("-"):
        raise argparse.ArgumentTypeError(f"the wall-time budget must be a positive, finite "
                                         f"time, got {given!r}")
    try:
        days = 0
        if "-" in text:
            d, text = text.split("-", 1)
            days = int(d)
        parts = [float(p) for p in text.split(":")]
        if not 1 <= len(parts) <= 3 or any(p < 0 for p in parts):
            raise ValueError
        secs = 0.0
        for p in parts:
            secs = 60.0 * secs + p
        secs += 86400.0 * days
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected seconds or [D-]H:M:S, got {given!r}") from None
    if not math.isfinite(secs) or secs <= 0:
        raise argparse.ArgumentTypeError(f"the wall-time budget must be a positive, finite "
                                         f"time, got {given!r}")
    return secs


def _cmd_check_env(args: argparse.Namespace) -> int:
    from micropit_hpc.checkenv import main as check_env

    return check_env(args.expect_ranks)


def _cmd_scene(args: argparse.Namespace) -> int:
    from micropit_hpc.plan import make_plan
    from micropit_hpc.scene import keys_markdown, load_scene

    if args.help_keys:
        print(keys_markdown())
        return 0
    if not args.scene:
        raise MicropitError("give a scene file to check, or --help-keys for the key reference")
    for path in args.scene:
        scene = load_scene(path)
        plan = make_plan(scene)   # every check `micropit run` makes before its first block
        if scene.gear is not None:
            pos = scene.positions
            n = pos.count if pos.kind == "count" else len(pos.values)
            what = f"gear pair z1 = {scene.gear.geometry.z1}, z2 = {scene.gear.geometry.z2}, " \
                   f"{n} positions given by {pos.kind.replace('_', ' ')}"
        else:
            what = f"disc rig, {len(scene.disc.slide_roll)} slide-roll ratios"
        print(f"{path}: valid scene '{scene.name}': {what}; {len(plan.items)} work items, "
              f"{plan.blocks} blocks, contact levels {', '.join(sorted(set(plan.levels)))}")
        if scene.lubricant.derived:
            print(f"  {scene.lubricant.derived}")
        _warn_scene(scene)
        for w in plan.warnings:
            print(f"micropit: warning: {w}", file=sys.stderr, flush=True)
        for p in plan.window_problems:
            print(f"micropit: warning: {scene.source}: the window does not hold the roughness: "
                  f"{p}", file=sys.stderr, flush=True)
    return 0


def _positive_int(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return int(text)


def _petsc_values_ok(extra: list[str]) -> bool:
    """True when ``extra`` reads as PETSc options: ``-name [value]`` pairs, values not
    starting with ``--``."""
    if not extra or not extra[0].startswith("-") or extra[0].startswith("--"):
        return False
    return not any(a.startswith("--") for a in extra)


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors are printed once under a launcher (by the rank the
    launcher numbers 0; every rank parses the same command line, before MPI starts)."""

    def error(self, message: str):
        if launcher_rank() == 0:
            self.print_usage(sys.stderr)
            sys.stderr.write(f"{self.prog}: error: {message}\n")
            sys.stderr.flush()
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
    common = _Parser(add_help=False)
    # SUPPRESS: a subcommand's parser must not reset a --debug given before the subcommand (the
    # action object is shared by every parser built from `common`: never set_defaults(debug=))
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the Python traceback of errors")
    parser = _Parser(
        prog="micropit", parents=[common],
        description="Micropitting of rough, lubricated rolling-sliding contacts (gears, disc "
                    "rigs). Scene keys: micropit scene --help-keys.")
    parser.add_argument("--version", action="version", version=f"micropit_hpc {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("contact", parents=[common],
                       help="contact conditions at every position of a scene",
                       description="Print the smooth contact conditions (load, Hertz, "
                                   "speeds, film, Λ) at every position of SCENE as CSV, "
                                   "after the path-of-contact summary (lines starting with #).")
    p.add_argument("scene", metavar="SCENE", help="scene file (TOML)")
    p.add_argument("--csv", metavar="FILE", help="also write the table to FILE (CSV only)")
    p.set_defaults(func=_cmd_contact)

    p = sub.add_parser("snapshot", parents=[common],
                       help="one time step of one position: fields, stresses, maps",
                       description="Solve one time step of one position of SCENE (contact "
                                   "pressure, clearance, solid contact, tractions and the "
                                   "stress tensor on every depth layer of both bodies) and "
                                   "write DIR/snapshot.h5 and DIR/snapshot.png.")
    p.add_argument("scene", metavar="SCENE", help="scene file (TOML)")
    p.add_argument("--position", type=_positive_int, default=1, metavar="K",
                   help="position number, 1-based, as in `micropit contact` (default 1)")
    p.add_argument("--step", type=_positive_int, default=None, metavar="J",
                   help="time step, 1-based, of window.steps (default: the middle one)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.set_defaults(func=_cmd_snapshot)

    p = sub.add_parser("run", parents=[common],
                       help="the life simulation of every work item of a scene",
                       description="Run the life simulation (blocks of ΔN load cycles: "
                                   "contact, stresses, Dang Van damage, wear, micropits) of "
                                   "every work item of SCENE (positions × wear coefficients × "
                                   "roughness scales × patches) on all ranks, and write "
                                   "DIR/summary.csv and DIR/results.h5 (docs/outputs.md).")
    p.add_argument("scene", metavar="SCENE", help="scene file (TOML)")
    p.add_argument("--out", required=True, type=_out_dir, metavar="DIR",
                   help="output folder: one run's; locked while the run lives; refused if it "
                        "holds another run's results or checkpoints (see --restart, "
                        "--overwrite)")
    p.add_argument("--position", type=_positive_int, action="append", default=None,
                   metavar="K", help="only position K (repeat for several; default all)")
    p.add_argument("--ranks-per-item", type=_positive_int, default=1, metavar="R",
                   help="ranks per work item: each item's window is split over R ranks "
                        "(default 1: items spread over all ranks)")
    p.add_argument("--balance", choices=("dynamic", "static"), default="dynamic",
                   help="how items are spread over the groups of ranks: dynamic (default) "
                        "hands every block's items out as groups free up, the likely "
                        "costliest first (by k_lub, then the slip over the transit), moving "
                        "items' states between groups; static keeps round robin (a restart: "
                        "longest-first). Never changes the numbers")
    p.add_argument("--restart", action="store_true",
                   help="resume from the checkpoint DIR/checkpoints/LATEST names (any number "
                        "of ranks), after verifying it; a damaged one falls back to the "
                        "previous good one; start afresh if there is none")
    p.add_argument("--overwrite", action="store_true",
                   help="delete the results and checkpoints of a previous run in DIR and "
                        "start afresh (without it a fresh run refuses such a folder)")
    p.add_argument("--force", action="store_true",
                   help="with --restart: accept a checkpoint written for a different scene "
                        "(the work items and window must still match)")
    p.add_argument("--max-wall", type=_wall_time, default=None, metavar="TIME",
                   help="wall-time budget (seconds or [D-]H:M:S): stop at the block "
                        "boundary where the next block (1.2 × the longest so far, plus a "
                        "checkpoint) would overrun it, checkpoint, exit 85. Default under "
                        "Slurm: the job's end (SLURM_JOB_END_TIME) less 120 s")
    p.add_argument("--ignore-memory-estimate", action="store_true",
                   help="run even when the up-front memory estimate (printed) exceeds the "
                        "memory available on this node")
    p.add_argument("--quiet", action="store_true",
                   help="no progress lines on stderr (notes, warnings, checkpoint fallbacks "
                        "and errors are still written)")
    p.add_argument("--stop-file", default=None, metavar="FILE",
                   help="stop at the next block boundary once FILE exists (checkpoint, "
                        "exit 85)")
    p.epilog = ("Arguments after the options that start with '-' and are not micropit "
                "options go to PETSc: -log_view (profile by stage), -options_left, "
                "-micropit_checkpoint_keep K (checkpoints kept, default 3), "
                "-micropit_checkpoint_every K (blocks between checkpoints, default 1). "
                "SIGUSR1, SIGTERM, the stop file and --max-wall end the run at a block "
                "boundary with a checkpoint and exit code 85 (jobs/ requeue on it).")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("check-env", parents=[common],
                       help="check MPI, parallel HDF5, PETSc and FFTW (run under mpirun)",
                       description="Check that this environment can run micropit_hpc in "
                                   "parallel; exit 1 naming each problem.")
    p.add_argument("--expect-ranks", type=_positive_int, metavar="N",
                   help="fail unless exactly N ranks are running")
    p.set_defaults(func=_cmd_check_env)

    p = sub.add_parser("scene", parents=[common], help="check scene files; list every key",
                       description="Validate scene files, or print the reference of every "
                                   "scene key (--help-keys).")
    p.add_argument("scene", nargs="*", metavar="SCENE", help="scene files to check")
    p.add_argument("--help-keys", action="store_true",
                   help="print every scene key with unit, default, range and meaning")
    p.set_defaults(func=_cmd_scene)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    if extra:
        bad = [a for a in extra if not a.startswith("-") or a.startswith("--")]
        if args.command != "run" or (bad and not _petsc_values_ok(extra)):
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
    args.petsc_options = extra
    args.process_entry = argv is None   # the command itself, not a call from Python
    try:
        return args.func(args)
    except (Exception, KeyboardInterrupt) as e:  # every error ends the job
        return _fail(e, getattr(args, "debug", False))


#: Seconds the ranks wait for each other after an error every rank raised (collective): if a
#: rank does not arrive, the error was not collective after all and the job is aborted.
COLLECTIVE_EXIT_WAIT_S = 10.0


def _mpi_world():
    """COMM_WORLD when MPI is initialised and running, else None (never initialises MPI)."""
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is None or not mpi.Is_initialized() or mpi.Is_finalized():
        return None
    return mpi.COMM_WORLD


def _fail(e: BaseException, debug: bool) -> int:
    """Report ``e`` once and end the job (one rank's error must not hang the others; docs/jobs.md).

    A user error (:class:`MicropitError`) is one line ``micropit: error: ...``; any other
    exception is a bug: its traceback (one rank only) and a one-line summary. On one rank the
    exit code is returned. Under MPI a *collective* error (every rank raised it, e.g. a bad
    scene or an agreed checkpoint verdict) is printed by rank 0 and every rank returns; a
    rank-local error is printed by the rank that had it, which then calls ``MPI_Abort``: the
    other ranks may be waiting for it in a collective call and would otherwise spin forever.
    """
    import traceback

    from micropit_hpc.parallel.failure import abort_job, is_bug, one_line, say

    text, code = one_line(e)
    comm = _mpi_world()
    size = comm.Get_size() if comm is not None else 1
    if size == 1:
        if debug or is_bug(e):
            raise e
        if comm is None and getattr(e, "collective", False) and launcher_rank() > 0:
            return code  # MPI not started, every rank read the same file: rank 0 says it
        say(f"micropit: error: {text}")
        return code
    if getattr(e, "collective", False):
        if comm.Get_rank() == 0:
            if debug:
                traceback.print_exception(e)
            say(f"micropit: error: {text}")
        if _wait_for_all(comm, COLLECTIVE_EXIT_WAIT_S):
            return code
        e = MicropitError(f"{text} (the other ranks did not meet this error within "
                          f"{COLLECTIVE_EXIT_WAIT_S:g} s; aborting the job)")
    abort_job(e, comm, debug)
    return code  # not reached


def _wait_for_all(comm, timeout_s: float) -> bool:
    """True when every rank reaches this point within ``timeout_s`` (a non-blocking barrier)."""
    import time

    req = comm.Ibarrier()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if req.Test():
            return True
        time.sleep(0.01)
    return False


