"""Rows of the benchmark scripts: printed as CSV lines while they run, written to a CSV file
at the end (the wear benchmarks: bench_wear.py, bench_wear_solver.py, bench_min_sub_block.py,
bench_wear_convergence.py)."""

from __future__ import annotations

import csv
from collections.abc import Sequence


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
