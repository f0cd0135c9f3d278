"""benchmarks/bench_tip_lives.py's CSV: each row names its scene and process length, a second
run appends under the same header, and a file of other columns is refused untouched."""

from __future__ import annotations

import csv

import pytest
from helpers import load_benchmark


def test_rows_are_appended_under_one_header_and_other_columns_refused(tmp_path):
    bench = load_benchmark("bench_tip_lives")
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
