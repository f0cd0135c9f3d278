"""Convergence of the wear–fatigue competition with the grid and the block length (issue 29,
docs/performance.md "Convergence of the wear"): combined mean wear depth, R_q, Δq and A_p per
body of one work item after each block, at several grids n² (the same physical window) and
block lengths ΔN.

The surfaces are one realisation made on the ``--ref`` grid (default 256²) and resampled
(antialiased) to each grid, so that a grid's difference is its discretisation, not another
roughness sample. Each run uses the scene's settings otherwise (the converged default:
adaptive blocks, implicit wear); ``--grids`` runs at the scene's ΔN, ``--blocks-M`` at the
scene's grid (those first). One rank, one process. Rows go to ``--csv`` as they finish; a
re-run skips the runs whose rows there reach ``--cycles-M`` (same process length ℓ, case,
k_lub, n and ΔN; a CSV without the ℓ column, from before 2026-12-02, is refused); one
that stops short starts again from its first block, or with ``--state`` from its last.
``--relief-share`` and ``--anderson-memory`` change the implicit wear's solver (docs/life.md,
"Implicit wear"; give such runs their own ``--csv`` and ``--state``: neither the skip nor the
state files tell them apart).

``--state DIR`` keeps each run's item state (what a checkpoint holds,
:func:`micropit_hpc.state.carried`) in ``DIR`` after every block, so that a run of hours can be
killed and continued: called again with the same options, a run whose CSV rows stop short of
``--cycles-M`` goes on from its last block, to the same numbers bit for bit as a run straight
through, its wall column counting on from the time already spent. A state is continued only by
the code that made it (the git tree of ``micropit_hpc/``, committed); another tree, or
uncommitted changes, is refused with the file to delete to start afresh.

    python benchmarks/bench_wear_convergence.py --position 3 --k-lub 5e-11 --grids 64 128 \\
        --blocks-M 1 0.5 0.25 0.1 --cycles-M 3 --csv benchmarks/results/wear_convergence.csv
    python benchmarks/bench_wear_convergence.py --scene scenes/paper_mpr.toml --k-lub 1e-11 \\
        --grids 128 --blocks-M --cycles-M 6 --csv rig.csv --state runs/rig_state
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from table import emit, line

from micropit_hpc import implicit_wear
from micropit_hpc.conditions import contact_study
from micropit_hpc.plan import WorkItem, reference_half_width, window_grid
from micropit_hpc.scene import load_scene
from micropit_hpc.state import carried, restore_carried
from micropit_hpc.study import ItemRun
from micropit_hpc.surfaces.bodies import body_surface

ROOT = Path(__file__).resolve().parents[1]
COLUMNS = ("scene", "process_length_um", "position", "k_lub_s", "n", "block_M", "cycles_M",
           "wear_um",
           "Rq_um_1", "Rq_um_2", "dq_1", "dq_2", "Ap_1", "Ap_2", "phi", "sub_blocks",
           "wear_cycles", "wall_s")


def item_run(base, position, k_lub, n, block_M, reference, fatigue=True) -> ItemRun:
    """One work item of ``base`` on the n² grid of the same window, ΔN = ``block_M`` M cycles,
    on the ``reference`` surfaces resampled (:func:`reference_surfaces`); ``fatigue`` False: an
    S–N intercept of 1e5 MPa (no damage, no pits)."""
    scene = dataclasses.replace(
        base, window=dataclasses.replace(base.window, nx=n, ny=None),
        life=dataclasses.replace(base.life, block=block_M * 1e6))
    if not fatigue:
        scene = dataclasses.replace(scene, fatigue=dataclasses.replace(scene.fatigue, B=1e11))
    study = contact_study(scene)
    grid = window_grid(scene, reference_half_width(study))
    surfaces = tuple(s.resampled(grid) for s in reference)
    return ItemRun(scene, WorkItem(0, position, k_lub, 1.0, 0), base=study, surfaces=surfaces)


def reference_surfaces(base, ref: int):
    """Both bodies' surfaces of ``base`` made on the ref² grid of its window."""
    ref_scene = dataclasses.replace(base, window=dataclasses.replace(base.window, nx=ref,
                                                                      ny=None))
    ref_grid = window_grid(ref_scene, reference_half_width(contact_study(ref_scene)))
    return tuple(body_surface(ref_scene, i, ref_grid) for i in (1, 2))


def scene_name(base) -> str:
    """The scene's file stem, the CSV's first column and part of a state file's name."""
    return Path(base.source).stem if base.source else "scene"


def code_tree() -> str:
    """The committed git tree of ``micropit_hpc/``, or "" where there is no git checkout or
    the package has uncommitted changes (a state it writes is then never continued)."""
    def git(*args):
        out = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)
        return out.stdout.strip() if out.returncode == 0 else None
    tree = git("rev-parse", "HEAD:micropit_hpc")
    if not tree or git("status", "--porcelain", "--", "micropit_hpc"):
        return ""
    return tree


def state_path(directory: Path, scene: str, ell, position, k_lub, n, block_M, ref,
               fatigue) -> Path:
    """The state file of one run in ``directory`` (``ell``: the process length [µm])."""
    return directory / (f"{scene}_l{ell:g}_p{position}_k{k_lub:g}_n{n}_dN{block_M:g}_ref{ref}"
                        f"{'' if fatigue else '_nofatigue'}.npz")


def save_state(path: Path, run: ItemRun, tree: str, counts: tuple[int, int, float]) -> None:
    """``run``'s item state and the run's (sub-blocks, contact-only cycles, wall seconds) so
    far into ``path``, atomically (a temporary file renamed)."""
    tmp = path.with_name(path.name + ".tmp.npz")
    parts = carried(run.state)
    np.savez(tmp, tree=np.array(tree), counts=np.array(counts, dtype=float),
             **{f"part{i}": a for i, a in enumerate(parts)})
    os.replace(tmp, path)


def load_state(path: Path, run: ItemRun, tree: str) -> tuple[int, int, float]:
    """Restore ``run``'s item state from ``path`` (:func:`save_state`); the counts so far.
    Raises SystemExit naming the file when another code tree wrote it."""
    with np.load(path) as f:
        was = str(f["tree"])
        if not tree or was != tree:
            sys.exit(f"bench_wear_convergence: {path} was written by micropit_hpc tree "
                     f"'{was}', this checkout's is '{tree or 'uncommitted'}': only the same "
                     "committed code continues a run; delete the file to start it afresh")
        parts = [f[f"part{i}"] for i in range(len(carried(run.state)))]
        subs, wear_cycles, wall = (float(x) for x in f["counts"])
    restore_carried(run.state, parts)
    return int(subs), int(wear_cycles), wall


def _run(base, position, k_lub, n, block_M, cycles_M, reference, out, fatigue=True,
         state: Path | None = None, tree: str = ""):
    run = item_run(base, position, k_lub, n, block_M, reference, fatigue)
    subs, wear_cycles, before = 0, 0, 0.0
    if state is not None and state.exists():
        subs, wear_cycles, before = load_state(state, run, tree)
        print(f"# continued from {state} after {run.state.cycles / 1e6:g} M cycles",
              flush=True)
    t0 = time.perf_counter()
    while run.state.cycles < cycles_M * 1e6 * (1 - 1e-9):
        rec = run.run_block(min(run.life.block, cycles_M * 1e6 - run.state.cycles))
        subs += rec.sub_blocks
        wear_cycles += rec.wear_cycles
        wall = before + time.perf_counter() - t0
        row = (scene_name(base), base.fatigue.process_length * 1e6, position, k_lub, n, block_M,
               run.state.cycles / 1e6, sum(rec.wear_mean) * 1e6, rec.Rq[0] * 1e6,
               rec.Rq[1] * 1e6, rec.slope[0], rec.slope[1], rec.Ap[0], rec.Ap[1], rec.phi,
               subs, wear_cycles, wall)
        out(row)        # then the state: a kill between the two repeats the block's row
        if state is not None:
            save_state(state, run, tree, (subs, wear_cycles, wall))


def _done(path: Path) -> dict:
    """The cycles [M] each run of the CSV ``path`` has rows up to, by (process length [µm],
    position, k_lub, n, ΔN). A CSV of other columns (one written before the process length
    was a column: those rows are pointwise, and new rows would not fit under its header) is
    refused, naming the file."""
    if not path or not path.exists():
        return {}
    done = {}
    with open(path) as f:
        rows = csv.DictReader(f)
        if tuple(rows.fieldnames or ()) != COLUMNS:
            sys.exit(f"bench_wear_convergence: {path} has the columns {rows.fieldnames}, not "
                     f"{list(COLUMNS)} (written by an earlier version: without "
                     "process_length_um its rows are pointwise); give a new --csv")
        for r in rows:
            key = (float(r["process_length_um"]), r["position"], float(r["k_lub_s"]),
                   int(r["n"]), float(r["block_M"]))
            done[key] = max(done.get(key, 0.0), float(r["cycles_M"]))
    return done


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper_gear_z23.toml"))
    ap.add_argument("--position", type=int, default=3)
    ap.add_argument("--k-lub", type=float, nargs="+", default=[5e-11])
    ap.add_argument("--grids", type=int, nargs="*", default=[64, 128])
    ap.add_argument("--blocks-M", type=float, nargs="*", default=[1.0, 0.5, 0.25, 0.1])
    ap.add_argument("--cycles-M", type=float, default=3.0)
    ap.add_argument("--ref", type=int, default=256, help="grid of the surface realisation")
    ap.add_argument("--no-fatigue", action="store_true",
                    help="S–N intercept 1e5 MPa: no damage, no pits (the wear alone)")
    ap.add_argument("--relief-share", type=float, default=None,
                    help="θ of the implicit wear's preconditioner (default: "
                         "implicit_wear.RELIEF_SHARE); a solver experiment, not a scene key")
    ap.add_argument("--anderson-memory", type=int, default=None,
                    help="past iterates of the implicit wear's Anderson step (default: "
                         "implicit_wear.MEMORY)")
    ap.add_argument("--csv", default=None)
    ap.add_argument("--state", default=None, metavar="DIR",
                    help="keep each run's item state here after every block and continue a "
                         "run from it (module docstring)")
    a = ap.parse_args(argv)
    if a.relief_share is not None:
        implicit_wear.RELIEF_SHARE = a.relief_share
    if a.anderson_memory is not None:
        implicit_wear.MEMORY = a.anderson_memory
    base = load_scene(a.scene)
    reference = reference_surfaces(base, a.ref)
    path = Path(a.csv) if a.csv else None
    done = _done(path)
    # the block lengths on the scene's grid first (the cheaper runs), then the other grids
    runs = [(base.window.nx, b) for b in a.blocks_M]
    runs += [(n, base.life.block / 1e6) for n in a.grids if (n, base.life.block / 1e6) not in runs]
    if path and not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(",".join(COLUMNS) + "\n")
    print(",".join(COLUMNS), flush=True)

    def out(row):
        emit(row)
        if path:
            with open(path, "a") as f:
                f.write(line(row) + "\n")
    states = Path(a.state) if a.state else None
    if states is not None:
        states.mkdir(parents=True, exist_ok=True)
    tree = code_tree() if states is not None else ""
    scene = scene_name(base)
    ell = base.fatigue.process_length * 1e6     # the run key's ℓ [µm], as the rows'
    for k in a.k_lub:
        for n, block in runs:
            if done.get((ell, str(a.position), k, n, block), 0.0) >= a.cycles_M * (1 - 1e-9):
                continue
            state = None if states is None else state_path(
                states, scene, ell, a.position, k, n, block, a.ref, not a.no_fatigue)
            _run(base, a.position, k, n, block, a.cycles_M, reference, out,
                 fatigue=not a.no_fatigue, state=state, tree=tree)
    return 0


if __name__ == "__main__":
    sys.exit(main())
