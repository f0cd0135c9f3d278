"""Rows of the benchmark scripts: printed as CSV lines while they run, written to a CSV file
at the end (the wear benchmarks: bench_wear.py, bench_wear_solver.py, bench_min_sub_block.py,
bench_wear_convergence.py) or appended to one under a checked header (bench_tip_lives.py)."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path


def line(row: Sequence) -> str:
    """One row as a CSV line, floats to 5 significant digits."""
    return ",".join(f"{v:.5g}" if isinstance(v, float) else str(v) for v in row)


def emit(row: Sequence) -> None:
    print(line(row), flush=True)


def write_csv(path: str | None, columns: Sequence[str], rows: Sequence[Sequence]) -> None:
    """All ``rows`` under ``columns`` to ``path`` (nothing when None)."""
    if path:
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(columns)
            w.writerows(rows)


def append_csv(path: str | None, columns: Sequence[str], rows: Sequence[Sequence],
               who: str) -> None:
    """``rows`` appended to ``path`` under ``columns`` (the header written when the file is new
    or empty); a file whose header is not ``columns`` is refused, naming it and ``who`` (the
    benchmark), before anything is written. Nothing when ``path`` is None."""
    if not path:
        return
    f = Path(path)
    new = not (f.exists() and f.stat().st_size)
    if not new:
        with open(f, newline="") as fh:
            header = next(csv.reader(fh), [])
        if tuple(header) != tuple(columns):
            raise SystemExit(f"{who}: {f} has the columns {','.join(header)}, not "
                             f"{','.join(columns)}: give --csv another file")
    f.parent.mkdir(parents=True, exist_ok=True)
    with open(f, "a", newline="") as fh:
        w = csv.writer(fh)
        if new:
            w.writerow(columns)
        w.writerows(rows)
