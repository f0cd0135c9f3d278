"""Progress reports: plain lines in a log, a bar on a terminal, the time-left arithmetic."""

from __future__ import annotations

import io
import math

import pytest

from micropit_hpc.progress import NullProgress, Progress, format_duration


class FakeClock:
    def __init__(self, t=0.0):
        self.t = t

    def __call__(self):
        return self.t


def make(total=10, **kw):
    clock, out = FakeClock(), io.StringIO()
    kw.setdefault("tty", False)
    return Progress(total, "blocks", stream=out, clock=clock, **kw), clock, out


@pytest.mark.parametrize("seconds,text", [(0, "0:00:00"), (62.4, "0:01:02"), (144.67, "0:02:25"),
                                          (3725, "1:02:05"), (90000, "25:00:00"),
                                          (math.nan, "?"), (math.inf, "?")])
def test_format_duration(seconds, text):
    assert format_duration(seconds) == text


def test_plain_lines_with_eta_from_the_mean_time_per_unit():
    p, clock, out = make(min_interval_s=0)
    clock.t = 62.0
    p.update(3, "position 4")
    # 62 s for 3 blocks: 20.67 s per block, 7 left -> 144.7 s
    assert out.getvalue() == ("[progress] 3/10 blocks (30%) elapsed 0:01:02 ETA 0:02:25 "
                              "— position 4\n")
    clock.t = 100.0
    p.update(10)
    assert out.getvalue().splitlines()[-1] == ("[progress] 10/10 blocks (100%) elapsed 0:01:40 "
                                               "ETA 0:00:00")


def test_eta_is_unknown_before_the_first_unit_and_excludes_restarted_units():
    p, clock, out = make(initial=4, min_interval_s=0)
    clock.t = 5.0
    assert math.isnan(p.eta(4))
    p.update(4)
    assert "ETA ?" in out.getvalue()
    clock.t = 60.0
    assert p.eta(6) == pytest.approx(60.0 / 2 * 4)  # 2 blocks in this run, 4 left
    p.update(6)
    assert out.getvalue().splitlines()[-1].endswith("elapsed 0:01:00 ETA 0:02:00")


def test_reports_are_rate_limited_except_the_last():
    p, clock, out = make(min_interval_s=10)
    for t, done in [(1, 1), (5, 2), (11.5, 3), (20, 4), (21.5, 5), (22, 10), (23, 10)]:
        clock.t = t
        p.update(done)
    lines = out.getvalue().splitlines()
    assert [line.split()[1] for line in lines] == ["1/10", "3/10", "5/10", "10/10"]


def test_defaults_follow_the_stream():
    p = Progress(3, "items", stream=io.StringIO())
    assert p.tty is False and p.min_interval_s == 10.0

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    p = Progress(3, "items", stream=Terminal())
    assert p.tty is True and p.min_interval_s == 0.2


def test_terminal_bar_redraws_one_line():
    p, clock, out = make(total=4, tty=True, min_interval_s=0)
    clock.t = 30.0
    p.update(1, "a long note about position 12")
    clock.t = 60.0
    p.update(2)
    text = out.getvalue()
    first, second = text.split("\r")[1:]
    assert "\n" not in text
    assert first == "blocks [######------------------] 1/4  25% 0:00:30 ETA 0:01:30 — " \
                    "a long note about position 12"
    assert second.startswith("blocks [############------------] 2/4  50% 0:01:00 ETA 0:01:00")
    assert len(second) == len(first)  # padded over the longer previous line
    p.close()
    assert out.getvalue().endswith("\n")
    p.close()
    assert out.getvalue().count("\n") == 1


def test_the_final_bar_ends_the_line():
    p, clock, out = make(total=2, tty=True, min_interval_s=100)
    clock.t = 1.0
    p.update(1)
    p.update(2)  # within the interval, but final
    assert out.getvalue().endswith("2/2 100% 0:00:01 ETA 0:00:00\n")
    with p:
        pass
    assert out.getvalue().count("\n") == 1


def test_null_progress_has_the_same_api():
    public = {n for n in dir(Progress) if not n.startswith("_")} - {"eta", "line"}
    assert public <= {n for n in dir(NullProgress) if not n.startswith("_")}
    with NullProgress(10, "blocks") as p:
        p.update(3, "note")


# ---- inside blocks (issue 20) -------------------------------------------------------------
def test_block_fraction_counts_items_and_cycles_inside_the_block():
    from micropit_hpc.progress import block_fraction

    assert block_fraction(1, 0, 4, 0.0, 1e6) == 0.0
    assert block_fraction(1, 1, 4, 0.5e6, 1e6) == pytest.approx(0.375)   # (1 + 0.5)/4
    assert block_fraction(3, 3, 4, 1e6, 1e6) == pytest.approx(3.0)
    assert block_fraction(2, 0, 1, 2e6, 1e6) == pytest.approx(2.0)      # clipped to the block


def test_an_item_from_the_queue_is_placed_among_the_blocks_items():
    """With --balance dynamic a group's items come from the shared queue (docs/hpc.md §2): the
    report places the item among the block's items as handed out, not among the rank's."""
    from micropit_hpc.plan import WorkItem
    from micropit_hpc.progress import inside_note

    item = WorkItem(26, 9, 5e-11, 1.0, 0)
    args = (2, item, 26, 33, 0.5e6, 1e6, 3, 4, 62)
    assert ("item 26 (position 9), 27 of 33 handed out, sub-block 3, 0.5 of 1 M cycles, "
            "step 4/62") in inside_note(*args, True)
    assert "27 of 33 on this rank, " in inside_note(*args)


def test_fractional_progress_shows_two_decimals_and_an_eta_once_it_means_something():
    """No ETA before the run has done a whole block: a quarter of the first block extrapolated
    (start-up included) said "ETA 2:44:38" on the first line of a 24 s run."""
    p, clock, out = make(total=3)
    p.update(0, "starting")
    clock.t = 30.0
    p.update(0.25, "block 1: item 0")
    clock.t = 60.0
    p.update(1.5, "block 2: item 0")
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("[progress] 0/3 blocks (0%)") and "ETA ?" in lines[0]
    assert lines[1] == ("[progress] 0.25/3 blocks (8%) elapsed 0:00:30 ETA ? — "
                        "block 1: item 0")
    # 1.5 blocks in 60 s ⇒ 1.5 blocks left take 60 s
    assert lines[2] == ("[progress] 1.50/3 blocks (50%) elapsed 0:01:00 ETA 0:01:00 — "
                        "block 2: item 0")


def test_a_one_block_run_shows_its_eta_from_half_the_block():
    p, clock, _ = make(total=1)
    clock.t = 10.0
    assert math.isnan(p.eta(0.25)) and p.eta(0.5) == pytest.approx(10.0)


def test_reports_inside_a_unit_never_hold_back_the_first_units_line():
    """The start line and the reports inside block 1 do not delay the line of block 1 done (a
    job script waits for it), though they are rate-limited among themselves."""
    p, clock, out = make(total=3)
    p.update(0, "starting", milestone=False)
    clock.t = 1.0
    p.update(0.5, "inside", milestone=False)          # within 10 s of the start: held back
    clock.t = 2.0
    p.update(1, "block 1")                             # the first milestone: written
    clock.t = 3.0
    p.update(2, "block 2")                             # within 10 s of block 1: held back
    lines = out.getvalue().splitlines()
    assert [ln.split(" — ")[1] for ln in lines] == ["starting", "block 1"]


@pytest.mark.slow
def test_a_run_reports_inside_its_blocks_and_is_silent_with_quiet(tmp_path, capsys, monkeypatch):
    """`micropit run` writes a first line at once, then lines inside the block (item,
    sub-block, time step) with an ETA; --quiet writes none of them (the notes and warnings
    stay)."""
    from helpers import tiny_doc, write_scene

    import micropit_hpc.progress as progress
    from micropit_hpc.cli import main

    monkeypatch.setattr(progress, "LOG_INTERVAL_S", 0.0)      # every report, not every 10 s
    doc = tiny_doc(slide_roll=(0.3, 0.2))
    doc["life"] = {"cycles_M": 1.0, "block_M": 1.0, "max_splits": 2}
    doc["window"] = {"n": 16, "steps": 3, "steps_per_peak_spacing": 0.25}   # 3 steps, not 24
    doc["stress"] = {"layers": 3}
    doc["body1"]["surface"]["corr_y_um"] = 300.0     # a window that does not hold it: warned
    scene = write_scene(tmp_path / "tiny.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "a")]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("[progress]")]
    assert err[0].startswith("[progress] 0/1 blocks") and err[0].endswith("starting")
    inside = [ln for ln in err if "sub-block" in ln]
    for item, pos in ((0, 1), (1, 2)):
        for step in (1, 2, 3):
            assert any(f"item {item} (position {pos}), {item + 1} of 2 on this rank, "
                       f"sub-block 1, 0 of 1 M cycles, step {step}/3" in ln for ln in inside)
    assert any(ln.startswith("[progress] 0.50/1 blocks") and "ETA 0:" in ln for ln in inside)
    assert err[-1].startswith("[progress] 1/1 blocks (100%)")
    assert main(["run", str(scene), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    quiet = capsys.readouterr().err.splitlines()
    assert any(ln.startswith("# warning: block 1") for ln in quiet)    # warnings stay
    assert any("the window does not hold the roughness" in ln for ln in quiet)
    assert not [ln for ln in quiet if ln.startswith("[progress]")]
    assert any(ln.startswith("# estimate:") for ln in quiet)
