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
