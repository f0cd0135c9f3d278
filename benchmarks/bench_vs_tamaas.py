"""Side by side with Tamaas: the same elastic rough contact solved by micropit_hpc's dry solver
and by Tamaas 2.9's Polonsky–Keer solver, time against accuracy.

Surfaces: the Gaussian transverse-lay surface of ``bench_contact.py`` (β_x 30 µm, β_y 300 µm,
R_q 1 µm, 0.4 mm window, seed 1) at each size, loaded to about 20 % contact, both bodies
elastic (E' = 230.8 GPa), no pressure cap (Tamaas's solver is elastic). Tamaas gets the same
heights, window and load, with its contact modulus E* = E'/2 (the same Westergaard operator
2/(E*|k|) per mode, so both solve one discrete problem). One core each (OMP_NUM_THREADS=1).

Accuracy: the relative L2 distance of each solution's pressure from a reference, our solve at
ε ≤ 1e-13 (``bench_multilevel.reference``: 3×, 10× looser where the residual stalls at
round-off); Tamaas's tightest solve against it shows that both solve the same problem.
Time: median of ``--repeat`` cold solves per tolerance (each code's own tolerance: ours the
relative residual of docs/contact.md, Tamaas's its own error measure). Prints a markdown table
and, per size, the time each code needs to reach a pressure error of 1e-6 and their ratio;
writes ``benchmarks/results/vs_tamaas.csv``. Timings, not tests (docs/performance.md §10).

    .venv/bin/python benchmarks/bench_vs_tamaas.py [--sizes 128 256 512] [--repeat 3]

Tamaas runs in a virtual environment of its own (``bash benchmarks/setup_tamaas.sh`` makes it,
``--tamaas-python`` names another), as a worker process of this script (``--worker IN OUT``).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import csv  # noqa: E402
import datetime  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
TOLS = (1e-4, 1e-6, 1e-8, 1e-10)
TARGET = 1e-6          # the pressure error at which the two codes' times are compared


def worker(path_in: str, path_out: str) -> None:
    """Run under Tamaas's interpreter: solve the problems in ``path_in`` (npz), write the
    pressures and times to ``path_out``."""
    import tamaas as tm

    tm.set_log_level(tm.LogLevel.error)
    d = np.load(path_in)
    n, L, P = int(d["n"]), float(d["L"]), float(d["P"])

    def solve(tol):
        """A fresh model and solver (a cold start, as ours); returns (pressure, time)."""
        model = tm.Model(tm.model_type.basic_2d, [L, L], [n, n])
        model.E, model.nu = float(d["E_star"]), 0.0
        solver = tm.PolonskyKeerRey(model, d["heights"], float(tol))
        solver.max_iter = 100000
        t0 = time.perf_counter()
        solver.solve(P)
        return np.array(model.traction).reshape(n, n), time.perf_counter() - t0

    solve(1e-4)      # untimed: Tamaas's FFT plans for this shape are made here, as ours were
    out = {}
    for i, tol in enumerate(d["tols"]):
        runs = [solve(tol) for _ in range(int(d["repeat"]))]
        out[f"p{i}"] = runs[-1][0]
        out[f"t{i}"] = np.array([t for _, t in runs])
    np.savez(path_out, **out)


def tamaas_python(given: str | None) -> str:
    if given:
        return given
    return subprocess.run(["bash", str(HERE / "setup_tamaas.sh")], check=True,
                          capture_output=True, text=True).stdout.strip().splitlines()[-1]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tamaas-python", default=None)
    ap.add_argument("--worker", nargs=2, metavar=("IN", "OUT"), help=argparse.SUPPRESS)
    ap.add_argument("--csv", default=str(HERE / "results" / "vs_tamaas.csv"))
    args = ap.parse_args(argv)
    if args.worker:
        worker(*args.worker)
        return

    sys.path.insert(0, str(HERE))
    sys.path.insert(0, str(ROOT))
    from bench_contact import E_PRIME, load_for_area
    from bench_multilevel import reference

    from micropit_hpc import source_commit
    from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
    from micropit_hpc.spectral import Grid
    from micropit_hpc.surfaces import gaussian_surface

    py = tamaas_python(args.tamaas_python)
    version = subprocess.run([py, "-c", "import tamaas; print(tamaas.__version__)"],
                             check=True, capture_output=True, text=True).stdout.strip()
    print(f"Elastic rough contact, micropit_hpc against Tamaas {version}, one core each, median "
          f"of {args.repeat} cold solves — {datetime.date.today().isoformat()}, commit "
          f"{source_commit()}")
    print()
    print("| grid | code | tolerance | time [s] | pressure error | contact area |")
    print("|---|---|---|---|---|---|")
    rows, summary = [], []
    for n in args.sizes:
        L = 4e-4
        grid = Grid(n, n, L, L)
        z = gaussian_surface(grid, 1e-6, 30e-6, 300e-6, seed=1).heights
        gap0 = z.max() - z
        hs = ElasticHalfSpaces(grid, E_PRIME)
        P = load_for_area(gap0, hs)
        ref = reference((gap0, hs, P, np.inf), 1e-13)
        norm = float(np.linalg.norm(ref))

        def error(p, ref=ref, norm=norm):
            return float(np.linalg.norm(p - ref)) / norm

        ours = []
        for tol in TOLS:
            times, sol = [], None
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                sol = solve_dry_contact(gap0, hs, P, tol=tol, max_iter=100000)
                times.append(time.perf_counter() - t0)
            ours.append((tol, statistics.median(times), error(sol.pressure),
                         float((sol.pressure > 0).mean())))
        with tempfile.TemporaryDirectory() as tmp:
            src, dst = Path(tmp, "in.npz"), Path(tmp, "out.npz")
            np.savez(src, heights=z, n=n, L=L, P=P, E_star=E_PRIME / 2, tols=np.array(TOLS),
                     repeat=args.repeat)
            subprocess.run([py, str(Path(__file__).resolve()), "--worker", str(src), str(dst)],
                           check=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
            got = np.load(dst)
            theirs = [(tol, float(np.median(got[f"t{i}"])), error(got[f"p{i}"]),
                       float((got[f"p{i}"] > 0).mean())) for i, tol in enumerate(TOLS)]
        for code, results in (("micropit_hpc", ours), (f"Tamaas {version}", theirs)):
            for tol, t, err, area in results:
                print(f"| {n}² | {code} | {tol:.0e} | {t:.4f} | {err:.2e} | {area:.4f} |",
                      flush=True)
                rows.append({"n": n, "code": code, "tolerance": tol, "time_s": round(t, 5),
                             "pressure_error": f"{err:.3e}", "area": round(area, 5)})
        reach = [next((t for _, t, err, _ in res if err <= TARGET), float("nan"))
                 for res in (ours, theirs)]
        summary.append((n, *reach))
    print()
    print(f"| grid | micropit_hpc to error ≤ {TARGET:.0e} [s] | Tamaas [s] | Tamaas / ours |")
    print("|---|---|---|---|")
    for n, a, b in summary:
        print(f"| {n}² | {a:.4f} | {b:.4f} | {b / a:.2f} |")
    Path(args.csv).parent.mkdir(parents=True, exist_ok=True)
    with open(args.csv, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
