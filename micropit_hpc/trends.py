"""The paper's micropitting trends for gears (docs/model.md §7, trends 2–6) as checks on A_p tables.

Morales-Espejel, Rycerz & Kadiric, Wear 398–399 (2018): Table 4 (A_p along the flank for k_lub =
0, 1e-11 and 5e-11 s), Table 5 (S fixed at ±0.044) and Table 8 (z = 18 against z = 23). The
absolute A_p depends on the roughness patch, which is not public, so only the trends are
checked. Each check compares mean A_p (over roughness patches) and returns a :class:`Verdict`
with the numbers it compared. How the words of docs/model.md §7 become inequalities:

* *pitch point*: the position of smallest |S| (S = 0 on the paper's position 6);
* *away from the pitch*: |S| > :data:`AWAY_FROM_PITCH` (0.1; the paper's positions 1–4, 8–11);
* *rising through the single-pair zone*: on each side of the pitch, A_p of the pitch point and
  the single-pair positions ordered outwards rises by at least :data:`RISE_PCT` (1) %-point at
  every step (a saturated 0, 99, 99, 99 does not rise);
* *no further rise in the double-pair zones* (plateau or fall): the largest A_p of a side's
  double-pair positions exceeds its outermost single-pair one by at most
  :data:`PLATEAU_FRACTION` (¼) of the rise across the single-pair zone (the paper's driver:
  85 → 91 % after a rise of 85 points);
* *next to the pitch point*: a single-pair position that is not the outermost of its side
  (the paper's 4–5 / 7–8);
* *flat*: a range of at most :data:`FLAT_RANGE_PCT` (10) %-points over the positions away
  from the pitch point.

The paper's own tables pass every check (tests/test_trends.py).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

__all__ = ["AWAY_FROM_PITCH", "FLAT_RANGE_PCT", "PLATEAU_FRACTION", "RISE_PCT", "FlankPoint",
           "Verdict",
           "trend2", "trend3", "trend4", "trend5", "trend6"]

AWAY_FROM_PITCH = 0.1
PLATEAU_FRACTION = 0.25
FLAT_RANGE_PCT = 10.0
RISE_PCT = 1.0
PITCH_AP_PCT = 0.1          # "A_p = 0 at the pitch point": below one cell in a thousand


@dataclass(frozen=True)
class FlankPoint:
    """A_p [%] of one body at one position of a flank study (mean over patches)."""

    position: int
    S: float
    single: bool
    ap: float


@dataclass(frozen=True)
class Verdict:
    """Whether a trend holds, and a one-line account of the numbers compared."""

    trend: int
    holds: bool
    text: str

    def line(self) -> str:
        return f"trend {self.trend}: {'PASS' if self.holds else 'FAIL'} — {self.text}"


def _fmt(points: Sequence[FlankPoint]) -> str:
    return ", ".join(f"{p.position}: {p.ap:.3g}" for p in points)


def _pitch(points: Sequence[FlankPoint]) -> FlankPoint:
    return min(points, key=lambda p: abs(p.S))


def _sides(points: Sequence[FlankPoint]) -> list[list[FlankPoint]]:
    """The positions on each side of the pitch point, ordered from the pitch outwards."""
    pitch = _pitch(points)
    sides = []
    for sign in (-1.0, 1.0):
        side = [p for p in points if p is not pitch and p.S * sign > 0]
        sides.append(sorted(side, key=lambda p: abs(p.S)))
    return sides


def _by_position(points: Sequence[FlankPoint]) -> dict[int, FlankPoint]:
    return {p.position: p for p in points}


def trend2(points: Sequence[FlankPoint]) -> Verdict:
    """k_lub = 0: A_p = 0 at the pitch point; rising away from it through the single-pair zone;
    no further rise (plateau or fall) in the double-pair zones."""
    pitch = _pitch(points)
    fails = []
    if pitch.ap >= PITCH_AP_PCT:
        fails.append(f"A_p at the pitch point (position {pitch.position}) is {pitch.ap:.3g} %")
    for side in _sides(points):
        single = [p for p in side if p.single]
        double = [p for p in side if not p.single]
        if not single:
            continue
        seq = [pitch, *single]
        if any(b.ap < a.ap + RISE_PCT for a, b in pairwise(seq)):
            fails.append(f"single-pair zone not rising from the pitch: {_fmt(seq)}")
        if double:
            rise = seq[-1].ap - pitch.ap
            extra = max(p.ap for p in double) - seq[-1].ap
            if extra > PLATEAU_FRACTION * max(rise, 0.0):
                fails.append(f"double-pair zone rises by {extra:.3g} points after {rise:.3g} "
                             f"across the single-pair zone: {_fmt(seq[-1:] + double)}")
    return Verdict(2, not fails, "; ".join(fails) or
                   "0 at the pitch, rising through the single-pair zone, plateau beyond: "
                   + _fmt(sorted(points, key=lambda p: p.position)))


def trend3(no_wear: Sequence[FlankPoint], wear: Sequence[FlankPoint]) -> Verdict:
    """k_lub = 1e-11 s against k_lub = 0: lower away from the pitch point; largest inside the
    single-pair zone next to the pitch point; lower towards tip and root."""
    fails = []
    ref = _by_position(no_wear)
    higher = [p for p in wear if abs(p.S) > AWAY_FROM_PITCH and p.ap >= ref[p.position].ap]
    if higher:
        fails.append("not lower than without wear at " + ", ".join(
            f"{p.position} ({p.ap:.3g} ≥ {ref[p.position].ap:.3g})" for p in higher))
    top = max(wear, key=lambda p: p.ap)
    inner = {p.position for side in _sides(wear)
             for p in [q for q in side if q.single][:-1]}
    if top.position not in inner:
        fails.append(f"largest A_p {top.ap:.3g} % at position {top.position}, not inside the "
                     f"single-pair zone next to the pitch (positions {sorted(inner)})")
    ends = [p for p in wear if not p.single and p.ap >= top.ap]
    if ends:
        fails.append(f"not lower towards tip and root: {_fmt(ends)}")
    return Verdict(3, not fails, "; ".join(fails) or
                   f"below k_lub = 0 away from the pitch, largest at position {top.position} "
                   f"({top.ap:.3g} %): " + _fmt(sorted(wear, key=lambda p: p.position)))


def trend4(mild: Sequence[FlankPoint], strong: Sequence[FlankPoint]) -> Verdict:
    """k_lub = 5e-11 s: the lowest A_p everywhere (below k_lub = 1e-11 s), flat along the
    flank."""
    fails = []
    ref = _by_position(mild)
    pitch = _pitch(strong)
    higher = [p for p in strong if p is not pitch and p.ap > ref[p.position].ap]
    if higher:
        fails.append("above k_lub = 1e-11 s at " + ", ".join(
            f"{p.position} ({p.ap:.3g} > {ref[p.position].ap:.3g})" for p in higher))
    away = [p.ap for p in strong if abs(p.S) > AWAY_FROM_PITCH]
    spread = max(away) - min(away) if away else 0.0
    if spread > FLAT_RANGE_PCT:
        fails.append(f"not flat: A_p spans {spread:.3g} points away from the pitch")
    return Verdict(4, not fails, "; ".join(fails) or
                   f"lowest everywhere and flat (range {spread:.3g} points): "
                   + _fmt(sorted(strong, key=lambda p: p.position)))


def trend5(points: Sequence[FlankPoint]) -> Verdict:
    """S fixed at ±0.044 (Table 5): A_p follows p0, the single-pair zone above the double-pair
    zones (the pitch point, S = 0, left out)."""
    pitch = _pitch(points)
    single = [p for p in points if p.single and p is not pitch]
    double = [p for p in points if not p.single]
    if not single or not double:
        return Verdict(5, False, "needs positions in both the single- and double-pair zones")
    lo, hi = min(p.ap for p in single), max(p.ap for p in double)
    return Verdict(5, lo > hi, f"single-pair zone {_fmt(single)} "
                   f"{'above' if lo > hi else 'NOT above'} double-pair zones {_fmt(double)}")


def trend6(z23: dict[float, float], z18: dict[float, float]) -> Verdict:
    """z = 18 against z = 23 at 0.7 m below the tip (Table 8), driver A_p by k_lub: more on
    z = 18 without wear, less with wear (k_lub = 1e-11 s)."""
    a0, b0 = z23.get(0.0), z18.get(0.0)
    a1, b1 = z23.get(1e-11), z18.get(1e-11)
    if None in (a0, b0, a1, b1):
        return Verdict(6, False, "needs k_lub = 0 and 1e-11 s for both gears")
    holds = b0 > a0 and b1 < a1
    return Verdict(6, holds, f"k_lub = 0: z18 {b0:.3g} vs z23 {a0:.3g} % "
                   f"({'more' if b0 > a0 else 'NOT more'}); k_lub = 1e-11 s: z18 {b1:.3g} vs "
                   f"z23 {a1:.3g} % ({'less' if b1 < a1 else 'NOT less'})")
