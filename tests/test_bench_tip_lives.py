"""benchmarks/bench_tip_lives.py's CSV: each row names its scene and process length, a second
run appends under the same header, and a file of other columns is refused untouched."""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _bench():
    if str(ROOT / "benchmarks") not in sys.path:         # its sibling modules
        sys.path.insert(0, str(ROOT / "benchmarks"))
    spec = importlib.util.spec_from_file_location(
        "bench_tip_lives", ROOT / "benchmarks" / "bench_tip_lives.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_rows_are_appended_under_one_header_and_other_columns_refused(tmp_path):
    bench = _bench()
    assert bench.COLUMNS[:2] == ("scene", "process_length_um")
    row = ["paper_gear_z23", 5.0] + [1] * (len(bench.COLUMNS) - 2)
    path = tmp_path / "sub" / "tips.csv"
    bench.append_rows(str(path), [])                    # a new file: the header alone
    bench.append_rows(str(path), [row])
    bench.append_rows(str(path), [row, row])
    lines = list(csv.reader(open(path, newline="")))
    assert tuple(lines[0]) == bench.COLUMNS and len(lines) == 4
    assert lines[1][:2] == ["paper_gear_z23", "5.0"]
    old = tmp_path / "old.csv"                           # a file of the columns before
    old.write_text(",".join(bench.COLUMNS[2:]) + "\n1,2\n")
    before = old.read_text()
    with pytest.raises(SystemExit, match=r"old\.csv has the columns position,.*another file"):
        bench.append_rows(str(old), [row])
    assert old.read_text() == before
    bench.append_rows(None, [row])                        # no --csv: nothing written
