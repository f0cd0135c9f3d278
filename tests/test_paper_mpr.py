"""The trend checks of docs/model.md §7 on the MPR rig (postprocess/paper_mpr.py, trends 1 and 7):
the paper's own numbers pass them, numbers that break a trend do not, only the roller (body 1)
and the last block count, and the side-by-side tables are written."""

from __future__ import annotations

import csv
import importlib.util

import pytest
from helpers import ROOT, read_table

from micropit_hpc.study import SUMMARY_COLUMNS

_spec = importlib.util.spec_from_file_location("paper_mpr", ROOT / "postprocess" / "paper_mpr.py")
paper_mpr = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(paper_mpr)


def _summary(run, rows):
    """summary.csv of a run from (S, Lambda, k_lub, cycles, A_p of the roller); the rings
    (body 2) get A_p values that would reverse every trend, so a check that read them fails."""
    run.mkdir(exist_ok=True)
    with open(run / "summary.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(SUMMARY_COLUMNS)
        for i, (s, lam, k, n, ap) in enumerate(rows):
            for body, value in ((1, ap), (2, 100.0 - ap)):
                w.writerow([i, 1, s, 1.1, lam, k, body, n, value, 0.5, 0.0, 0.2])
    return run


def _mpr_rows(ap):
    """ap[(|S|, cycles)] → rows, with S negative as on the rig's roller and an earlier block."""
    rows = [(-s, 0.176, 0.0, n, a) for (s, n), a in ap.items()]
    rows += [(-s, 0.176, 0.0, 1e6, 50.0) for s in (0.05, 0.15, 0.3)]
    return rows


def _paper_mpr():
    return {(float(r["abs_S"]), float(r["cycles_million"]) * 1e6): float(r["Ap_model_pct"])
            for r in read_table("mpr_triple_disc_Ap.csv")}


def test_trend1_passes_on_the_papers_model_and_writes_the_table(tmp_path):
    said = []
    assert paper_mpr.mpr(_summary(tmp_path / "run", _mpr_rows(_paper_mpr())), said.append)
    assert len(said) == 5 and all(line.endswith("holds") for line in said)
    table = list(csv.DictReader(open(tmp_path / "run" / "mpr_comparison.csv")))
    assert [float(r["Ap_ours_pct"]) for r in table] == [float(r["Ap_paper_model_pct"])
                                                        for r in table]


@pytest.mark.parametrize("change", [
    {(0.15, 6e6): 9.3},            # |S| 0.15 above 0.30 at 6 M
    {(0.05, 10e6): 3.0},           # A_p falls from 6 M (3.7) to 10 M at |S| 0.05
])
def test_trend1_fails_when_broken(tmp_path, change):
    ap = _paper_mpr() | change
    said = []
    assert not paper_mpr.mpr(_summary(tmp_path / "run", _mpr_rows(ap)), said.append)
    assert sum(line.endswith("FAILS") for line in said) == 1


def _table9_rows(k0, k1):
    lams = (0.1762, 0.2468, 0.3091)
    rows = [(0.3, lam, 0.0, 6e6, a) for lam, a in zip(lams, k0, strict=True)]
    rows += [(0.3, lam, 1e-11, 6e6, a) for lam, a in zip(lams, k1, strict=True)]
    rows += [(0.3, lam, k, 1e6, 0.0) for lam in lams for k in (0.0, 1e-11)]
    return rows


PAPER9 = ([7.19, 2.78, 0.24], [0.073, 0.080, 0.056])


def test_trend7_passes_on_the_papers_table9_and_writes_the_table(tmp_path):
    said = []
    assert paper_mpr.table9(_summary(tmp_path / "run", _table9_rows(*PAPER9)), said.append)
    assert len(said) == 3 and all(line.endswith("holds") for line in said[:2])
    # what the paper's numbers carry beyond one pitted column: wear cuts A_p ~100× at low Λ
    assert said[2].startswith("wear cuts A_p by [98.5×, 34.8×, 4.29×]")
    table = list(csv.DictReader(open(tmp_path / "run" / "table9_comparison.csv")))
    assert [r["Ap_ours_klub1e-11_pct"] for r in table] == ["0.073", "0.08", "0.056"]
    assert [r["Lambda_ours"] for r in table] == ["0.1762", "0.2468", "0.3091"]


@pytest.mark.parametrize("k0, k1, failing", [
    ([7.19, 2.78, 2.9], PAPER9[1], "k_lub = 0"),            # no rise from Λ 0.307 to 0.245
    (PAPER9[0], [16.1, 0.16, 0.0], "k_lub = 1e-11"),        # ours: keeps rising as Λ falls
    (PAPER9[0], [0.05, 0.06, 0.07], "k_lub = 1e-11"),       # falls all the way
])
def test_trend7_fails_when_broken(tmp_path, k0, k1, failing):
    said = []
    assert not paper_mpr.table9(_summary(tmp_path / "run", _table9_rows(k0, k1)), said.append)
    assert [failing in line for line in said if line.endswith("FAILS")] == [True]


def test_the_wear_cut_is_without_over_with_wear_per_lambda():
    assert paper_mpr._cuts([31.07, 3.76, 0.5066], [16.08, 0.1648, 0.0]) == "[1.93×, 22.8×, ∞]"
    assert paper_mpr._cuts([1.0, None], [0.5, 0.1]) == "[2×, —]"


def test_the_papers_model_is_bracketed_by_the_two_surface_variants(tmp_path):
    """MPR bracket: the paper's model A_p at 6 M lies between our β_x = 15 and 30 µm results
    at every |S| (in either order); one |S| outside fails it, and 10 M does not count."""
    model = _paper_mpr()
    lo = {k: v - 1.0 for k, v in model.items()}
    hi = {k: v + 2.0 for k, v in model.items()}
    said = []
    ok, table = paper_mpr.bracket(_summary(tmp_path / "a", _mpr_rows(hi)),
                                  _summary(tmp_path / "b", _mpr_rows(lo)), said.append)
    assert ok and said[0].endswith("holds") and len(table) == 6
    assert all(row[-1] == "yes" for row in table)
    below = lo | {(0.15, 6e6): model[(0.15, 6e6)] + 0.5}      # both variants above the model
    ok, table = paper_mpr.bracket(_summary(tmp_path / "c", _mpr_rows(hi)),
                                  _summary(tmp_path / "d", _mpr_rows(below)), said.append)
    assert not ok and said[-1].endswith("FAILS")
    assert [row[-1] for row in table if row[1] == "6"] == ["yes", "no", "yes"]
    late = lo | {(0.3, 10e6): 50.0}                             # 10 M is shown, not judged
    ok, _ = paper_mpr.bracket(_summary(tmp_path / "e", _mpr_rows(hi)),
                              _summary(tmp_path / "f", _mpr_rows(late)), said.append)
    assert ok
