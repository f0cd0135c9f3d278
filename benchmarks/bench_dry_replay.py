"""The dry solves of one work item's block, recorded once and replayed: their time per solve and
a fingerprint of their answers, to compare two versions of ``lubrication/dry.py`` on the solves
the life loop really makes (docs/performance.md §2, "The dry solves' bookkeeping").

``record`` runs one block of one item (as ``bench_item_profile.py``: the scene's converged
default, one 256² realisation resampled to ``--n``) and stores the arguments of every loaded
dry solve the mixed level makes (the undeformed gap, load, cap, tolerance, start, held columns)
in an ``.npz`` file. ``replay`` solves them again, ``--repeat`` times, and prints the median
wall time of the whole set, the CG iterations and the convolutions (each a forward and an
inverse transform) it took, and a SHA-256 of the pressures and gaps (equal fingerprints: the
same answers bit for bit).

    python benchmarks/bench_dry_replay.py record --position 3 --cycles-M 0.01 --out runs/dry_p3.npz
    python benchmarks/bench_dry_replay.py replay runs/dry_p3.npz --repeat 5

One core, one process; timings, not tests.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import hashlib  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_item_profile import add_item_arguments, item_from_arguments  # noqa: E402

from micropit_hpc import source_commit  # noqa: E402
from micropit_hpc.lubrication import dry, mixed  # noqa: E402
from micropit_hpc.spectral import Grid  # noqa: E402


def record(a) -> int:
    """One block of the item; every loaded dry solve's arguments into ``a.out``."""
    run = item_from_arguments(a)
    calls = []
    orig = mixed.solve_dry_contact

    def spy(gap0, hs, P, p_lim=np.inf, **kw):
        if P > 0.0 and len(calls) < a.max_solves:     # copies: the caller may reuse them
            kept = {k: (np.array(v) if isinstance(v, np.ndarray) else v) for k, v in kw.items()}
            calls.append((np.array(gap0), hs, float(P), float(p_lim), kept))
        return orig(gap0, hs, P, p_lim, **kw)

    mixed.solve_dry_contact = spy
    try:
        run.run_block(a.cycles_M * 1e6)
    finally:
        mixed.solve_dry_contact = orig
    if not calls:
        print("no loaded dry solve was made", file=sys.stderr)
        return 1
    hs = calls[0][1]
    if any(c[1].grid.shape != hs.grid.shape for c in calls):
        print("the solves used several grids", file=sys.stderr)
        return 1
    shape = hs.grid.shape
    out = {"grid": np.array([hs.grid.nx, hs.grid.ny, hs.grid.lx, hs.grid.ly]),
           "E_prime": np.array(hs.E_prime),
           "gap0": np.stack([c[0] for c in calls]),
           "P": np.array([c[2] for c in calls]), "p_lim": np.array([c[3] for c in calls]),
           "tol": np.array([c[4]["tol"] for c in calls]),
           "max_iter": np.array([c[4]["max_iter"] for c in calls]),
           "has_init": np.array([c[4].get("p_init") is not None for c in calls]),
           "p_init": np.stack([np.zeros(shape) if c[4].get("p_init") is None
                               else np.asarray(c[4]["p_init"], dtype=float) for c in calls]),
           "has_free": np.array([c[4].get("free") is not None for c in calls]),
           "free": np.stack([np.zeros(shape, bool) if c[4].get("free") is None
                             else np.asarray(c[4]["free"], bool) for c in calls])}
    np.savez(a.out, **out)      # uncompressed: a replay loads it in a fraction of a second
    print(f"{len(calls)} dry solves of position {a.position} at {shape[0]}×{shape[1]}, "
          f"{int(out['has_init'].sum())} warm, written to {a.out}")
    return 0


def replay(a) -> int:
    """Every recorded solve, ``a.repeat`` times: median wall, iterations, transforms, hash."""
    with np.load(a.file) as z:
        d = {k: z[k] for k in z.files}      # each read of an npz item loads it anew
    nx, ny, lx, ly = d["grid"]
    hs = dry.ElasticHalfSpaces(Grid(int(nx), int(ny), float(lx), float(ly)),
                               float(d["E_prime"]))
    transforms = [0]
    inner = hs.response

    def counted(p=None):
        transforms[0] += 1
        return inner(p)

    hs.response = counted
    n = len(d["P"])
    args = [(d["gap0"][i], float(d["P"][i]), float(d["p_lim"][i]),
             dict(tol=float(d["tol"][i]), max_iter=int(d["max_iter"][i]),
                  p_init=d["p_init"][i] if d["has_init"][i] else None,
                  free=d["free"][i] if d["has_free"][i] else None)) for i in range(n)]
    walls = []
    for _ in range(a.repeat):
        digest, iterations, transforms[0] = hashlib.sha256(), 0, 0
        t0 = time.perf_counter()
        for gap0, P, p_lim, kw in args:
            sol = dry.solve_dry_contact(gap0, hs, P, p_lim, **kw)
            iterations += sol.iterations
            digest.update(sol.pressure.tobytes())
            digest.update(sol.gap.tobytes())
        walls.append(time.perf_counter() - t0)
    med = statistics.median(walls)
    print(f"commit {source_commit()}: {n} solves at {int(nx)}×{int(ny)}: median "
          f"{med:.3f} s ({1e3 * med / n:.3f} ms per solve; min {min(walls):.3f}, max "
          f"{max(walls):.3f} s over {a.repeat}), {iterations} CG iterations, "
          f"{transforms[0]} convolutions, answers {digest.hexdigest()[:16]}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("record", help="record one item's dry solves")
    add_item_arguments(r, position=3, cycles_M=0.01)
    r.add_argument("--max-solves", type=int, default=5000, help="record at most this many")
    r.add_argument("--out", required=True, help=".npz file to write")
    p = sub.add_parser("replay", help="replay recorded dry solves")
    p.add_argument("file")
    p.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args(argv)
    return record(a) if a.command == "record" else replay(a)


if __name__ == "__main__":
    sys.exit(main())
