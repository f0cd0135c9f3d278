"""Progress of a long run: a one-line bar on a terminal, plain lines in a batch log.

Rank 0 only, by construction: the caller creates a :class:`Progress` on rank 0 and a
:class:`NullProgress` (same API, does nothing) elsewhere. The estimate of the time left is the
mean time per unit done so far in this run times the units left, shown once this run has done
a whole unit (or half the total, when that is less): before, the time is dominated by the
start-up (planning the FFTs, compiling the kernels) and the estimate means nothing.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TextIO

BAR_WIDTH = 24
#: The least seconds between two reports on a terminal and in a log (by default).
TTY_INTERVAL_S, LOG_INTERVAL_S = 0.2, 10.0


def format_duration(seconds: float) -> str:
    """``H:MM:SS`` (hours unbounded), or ``?`` when not known."""
    if seconds is None or not math.isfinite(seconds):
        return "?"
    s = max(0, round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


class Progress:
    """Report ``done`` out of ``total`` units (``label``: their name, e.g. ``"blocks"``).

    ``tty``: bar with ``\\r`` (True) or plain lines (False); default: whether ``stream`` is a
    terminal. ``min_interval_s``: the least time between two reports (default 0.2 s on a
    terminal, 10 s in a log); the last one (``done == total``) is always written.
    ``initial``: units already done when the run started (a restart), left out of the rate.
    ``clock`` is injectable for tests.
    """

    def __init__(self, total: int, label: str, stream: TextIO | None = None,
                 tty: bool | None = None, min_interval_s: float | None = None,
                 initial: int = 0, clock: Callable[[], float] = time.monotonic):
        self.total = int(total)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        if tty is None:
            isatty = getattr(self.stream, "isatty", None)
            tty = bool(isatty and isatty())
        self.tty = tty
        self.min_interval_s = (min_interval_s if min_interval_s is not None
                               else TTY_INTERVAL_S if tty else LOG_INTERVAL_S)
        self.initial = int(initial)
        self.clock = clock
        self.t0 = clock()
        self._last_report = -math.inf
        self._last_milestone = -math.inf
        self._last_done: int | None = None
        self._width = 0  # length of the bar now on the terminal line
        self._open_line = False

    def eta(self, done: float, now: float | None = None) -> float:
        """Seconds left at ``done`` units: mean time per unit so far × units left (NaN until
        this run has done one whole unit, or half the units when there are fewer than 2)."""
        now = self.clock() if now is None else now
        run = done - self.initial
        if run <= 0 or run < min(1.0, 0.5 * (self.total - self.initial)):
            return math.nan
        return (now - self.t0) / run * max(0, self.total - done)

    def line(self, done: float, note: str = "", now: float | None = None) -> str:
        """The report at ``done`` units (a fraction inside a unit shows two decimals),
        without ``\\r`` or newline."""
        now = self.clock() if now is None else now
        shown = f"{done:.2f}" if done != int(done) else f"{int(done)}"
        pct = 100.0 * done / self.total if self.total else 100.0
        elapsed = format_duration(now - self.t0)
        eta = format_duration(self.eta(done, now))
        tail = f" — {note}" if note else ""
        if self.tty:
            frac = min(done, self.total) / self.total if self.total else 1.0
            fill = round(BAR_WIDTH * frac)
            bar = "#" * fill + "-" * (BAR_WIDTH - fill)
            return (f"{self.label} [{bar}] {shown}/{self.total} {pct:3.0f}% {elapsed} "
                    f"ETA {eta}{tail}")
        return (f"[progress] {shown}/{self.total} {self.label} ({pct:.0f}%) elapsed {elapsed} "
                f"ETA {eta}{tail}")

    def update(self, done: float, note: str = "", milestone: bool = True) -> None:
        """Report ``done`` units (rate-limited, except for the final report). Milestones (a
        unit done) are limited against the last milestone only, so reports inside a unit
        (``milestone=False``, limited against any report) never hold back the first unit's
        line."""
        now = self.clock()
        final = done >= self.total
        if final and self._last_done == done:
            return  # the final report once
        last = self._last_milestone if milestone else self._last_report
        if not final and now - last < self.min_interval_s:
            return
        text = self.line(done, note, now)
        if self.tty:
            pad = " " * max(0, self._width - len(text))
            self.stream.write("\r" + text + pad + ("\n" if final else ""))
            self._width = 0 if final else len(text)
            self._open_line = not final
        else:
            self.stream.write(text + "\n")
        self.stream.flush()
        self._last_report, self._last_done = now, done
        if milestone:
            self._last_milestone = now

    def close(self) -> None:
        """End the bar's line on a terminal (after an interrupted run)."""
        if self._open_line:
            self.stream.write("\n")
            self.stream.flush()
            self._open_line = False
            self._width = 0

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def block_fraction(k: int, index: int, count: int, cycles_done: float,
                   block_cycles: float) -> float:
    """Blocks done inside block ``k`` (1-based) when the ``index``-th of ``count`` items (of
    the reporting rank's group, run one after another) has done ``cycles_done`` of its
    ``block_cycles``: (k − 1) + (index + cycles_done/block_cycles)/count."""
    inside = cycles_done / block_cycles if block_cycles > 0 else 1.0
    return (k - 1) + (index + min(max(inside, 0.0), 1.0)) / max(count, 1)


def inside_note(k: int, item, index: int, count: int, cycles_done: float,
                block_cycles: float, sub_block: int, step: int, steps: int,
                queued: bool = False) -> str:
    """What a report inside block ``k`` says: the item by id and position, its place among
    this group's items (``queued``: among the block's items as they are handed out), the
    sub-block, the cycles of the block done and the time step; for sub-block 0, the plastic
    running-in before the first block, its pass ``step`` of at most ``steps``."""
    place = "handed out" if queued else "on this rank"
    where = (f"block {k}: item {item.id} (position {item.position}), {index + 1} of {count} "
             f"{place}, ")
    if sub_block == 0:
        return where + f"plastic running-in, pass {step} of ≤ {steps}"
    return where + (f"sub-block {sub_block}, {cycles_done / 1e6:.3g} of "
                    f"{block_cycles / 1e6:.3g} M cycles, step {step}/{steps}")


class NullProgress:
    """The API of :class:`Progress` on ranks that do not report: does nothing."""

    def __init__(self, *args, **kwargs):
        pass

    def update(self, done: float, note: str = "", milestone: bool = True) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> NullProgress:
        return self

    def __exit__(self, *exc) -> None:
        pass


class ProgressHandler:
    """Progress of ``micropit run`` (a :class:`~micropit_hpc.runner.Handler`): a line at once,
    lines inside the blocks (item, sub-block, step, with ETA) and one per block, on rank 0
    unless ``quiet``."""

    def __init__(self, rank0: bool, quiet: bool = False):
        self.show = rank0 and not quiet
        self.bar: Progress | NullProgress = NullProgress()

    def start(self, study, blocks: int, start: int) -> None:
        self.bar = Progress(blocks, "blocks", initial=start) if self.show \
            else NullProgress(blocks, "blocks")
        self.bar.update(start, "starting", milestone=False)   # the first line, at once

    def progress(self, k: int, item, i: int, n: int, done: float, total: float, sub: int,
                 step: int, steps: int, queued: bool = False) -> None:
        self.bar.update(block_fraction(k, i, n, done, total),
                        inside_note(k, item, i, n, done, total, sub, step, steps, queued),
                        milestone=False)

    def block(self, k: int, blocks: int, records) -> None:
        ap = max((r[-1].Ap[0] for r in records.values() if r), default=0.0)
        self.bar.update(k, f"{k * len(records)} item-blocks of {blocks * len(records)}, "
                           f"max A_p body 1 {ap:.3g} %")

    def finish(self, outcome) -> None:
        self.bar.close()
