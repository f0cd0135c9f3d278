"""Rainflow cycle counting and Miner damage per load cycle, vectorised over material points.

Used by ``fatigue.counting = "rainflow"`` (docs/model.md §4.4): every material point has a
scalar history y(t) = τ̂(t) + α_DV σ_H(t) over the m time steps of one load cycle; the history
is rainflow-counted and the Palmgren–Miner damage of its cycles is summed,
d = Σ_c w_c / N(peak_c).

Counting
--------
* Reversals: runs of equal consecutive values are merged into one value; the reversals are the
  first and last values and every interior point where the slope changes sign.
* ``periodic=False``: the three-point rainflow algorithm of ASTM E1049-85 (reapproved 2017)
  §5.4.4. The most recent three reversals not yet discarded form the ranges X (newest) and Y (the
  one before). While X ≥ Y: if Y contains the starting point S (the oldest reversal kept), Y
  counts as a half cycle and S is discarded (the next point becomes S); otherwise Y counts as one
  full cycle and both its points are discarded. At the end, each range left (the residue) counts
  as a half cycle.
* ``periodic=True`` (our case: the history repeats every load cycle): the standard treatment of a
  repeating history (Downing & Socie, "Simple rainflow counting algorithms", Int. J. Fatigue 4
  (1982) 31–40; ASTM E1049-85 §5.4.5, simplified rainflow counting for repeating histories): the
  series is rotated to start at its maximum (the first one, if tied) and closed with that
  maximum, and every range Y with X ≥ Y counts as one full cycle. Because the first point is the
  global maximum, the counting closes with an empty residue: every cycle is a full cycle, none is
  a half cycle, and the result does not depend on where the load cycle was started.

Damage **[choice]**: a cycle is loaded by its peak, the larger of its two extreme values,
peak_c = max(y_a, y_b), not by its range or amplitude: a Dang Van-type criterion loads a cycle by
its maximum of τ̂ + α σ_H. The damage per load cycle is d = Σ_c w_c · damage_of(peak_c), with
w_c = 1 for a full cycle and 0.5 for a half cycle, summed per point in the order the cycles are
counted. Range and mean are reported by :func:`rainflow_cycles_1d` for users and tests only.
Note that with this choice a small wiggle near the top of the history counts as a whole cycle at
(almost) the full load; a history with numerical noise near its maximum is damaged more.

Vectorisation (:func:`rainflow_damage`)
----------------------------------------
All points are processed in lockstep, with a Python loop over the time steps and over the
bounded number of reduction passes per step, never over points. Each point has its own stack of
reversals (an array of shape (steps, points) with stack pointers ``lo``/``hi`` per point), its
newest value ``top`` kept apart, and the direction of its current run. A value that continues the
run moves ``top`` (the tentative reversal is extended); otherwise ``top`` is pushed and the value
becomes ``top``. The points whose ``top`` moved and that hold three reversals or more then run the
X ≥ Y test, in passes on a shrinking set of points (those that just counted a cycle). Testing a
tentative ``top`` gives the same cycles, in the same order, as testing the final reversal: X only
grows while the run continues (floating-point subtraction is monotone), and the ranges Y do not
depend on ``top``. For ``periodic=True`` the columns are first sorted by the row of their maximum,
so that the rotation is a few block copies. Every point sees only its own data and sums its own
damage in its own counting order, so its result is bitwise independent of the other points of the
batch and of the chunking (points are processed in chunks to bound the stack memory).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from itertools import pairwise

import numpy as np

__all__ = ["DamageFunction", "rainflow_cycles_1d", "rainflow_damage", "reversals"]

DamageFunction = Callable[[np.ndarray], np.ndarray]

# Stack entries (float64) per chunk of points: 2**22 entries = 32 MiB.
_CHUNK_ENTRIES = 1 << 22
# Most points per chunk: keeps the per-step work arrays cache-sized.
_CHUNK_POINTS_MAX = 1 << 14


def reversals(y: Sequence[float] | np.ndarray) -> np.ndarray:
    """The reversals (peaks and valleys) of ONE series, in order.

    Runs of equal consecutive values are merged; the first and last values are always kept, an
    interior value is kept where the slope changes sign. A constant series gives one value.
    Plain sequential code (the reference the vectorised counting is tested against).
    """
    values = np.asarray(y, dtype=np.float64)
    if values.ndim != 1:
        raise ValueError(f"reversals expects a 1-D series, got shape {values.shape}")
    merged: list[float] = []
    for v in values.tolist():
        if not merged or v != merged[-1]:
            merged.append(v)
    out: list[float] = merged[:1]
    for i in range(1, len(merged) - 1):
        if (merged[i] > merged[i - 1]) != (merged[i + 1] > merged[i]):
            out.append(merged[i])
    if len(merged) > 1:
        out.append(merged[-1])
    return np.array(out, dtype=np.float64)


def rainflow_cycles_1d(
    y: Sequence[float] | np.ndarray, periodic: bool = True
) -> list[tuple[float, float, float, float]]:
    """Rainflow cycles of ONE series, as a list of (range, mean, peak, weight) in counting order.

    ``range`` = |y_a − y_b|, ``mean`` = (y_a + y_b)/2, ``peak`` = max(y_a, y_b) of the cycle's two
    reversals y_a, y_b; ``weight`` is 1.0 for a full cycle and 0.5 for a half cycle. ``periodic``
    as in :func:`rainflow_damage` (see the module docstring for both algorithms). This is the plain
    sequential reference implementation; use :func:`rainflow_damage` for many series.
    """
    values = np.asarray(y, dtype=np.float64)
    if values.ndim != 1:
        raise ValueError(f"rainflow_cycles_1d expects a 1-D series, got shape {values.shape}")
    if values.size < 2:
        raise ValueError(f"a history needs at least 2 time steps, got {values.size}")
    if not np.all(np.isfinite(values)):
        raise ValueError("the history contains NaN or infinite values")
    seq = values.tolist()
    if periodic:
        k = int(np.argmax(values))
        seq = seq[k:] + seq[:k] + [seq[k]]
    cycles: list[tuple[float, float, float, float]] = []

    def count(a: float, b: float, weight: float) -> None:
        cycles.append((abs(a - b), 0.5 * (a + b), max(a, b), weight))

    stack: list[float] = []
    for point in reversals(seq).tolist():
        stack.append(point)
        while len(stack) >= 3:
            x_range = abs(stack[-1] - stack[-2])
            y_range = abs(stack[-2] - stack[-3])
            if x_range < y_range:
                break
            if len(stack) == 3 and not periodic:  # Y contains the starting point S
                count(stack[0], stack[1], 0.5)
                del stack[0]
            else:
                count(stack[-3], stack[-2], 1.0)
                del stack[-3:-1]
    if periodic:
        assert len(stack) == 1, "a history closed at its maximum leaves no residue"
    else:
        for a, b in pairwise(stack):
            count(a, b, 0.5)
    return cycles


def _damage(damage_of: DamageFunction, peak: np.ndarray) -> np.ndarray:
    dmg = np.asarray(damage_of(peak), dtype=np.float64)
    if dmg.shape != peak.shape:
        raise ValueError(
            f"damage_of must map an array of shape {peak.shape} to the same shape, "
            f"got {dmg.shape}"
        )
    return dmg


def _first_max(y: np.ndarray) -> np.ndarray:
    """Row of the first maximum of each column of ``y`` (m, n): np.argmax(y, axis=0), computed
    with contiguous row operations (a column-wise argmax strides through memory)."""
    top = y.max(axis=0)
    first = np.zeros(y.shape[1], dtype=np.intp)
    for t in range(y.shape[0] - 1, -1, -1):  # the earliest row written last wins
        first[y[t] == top] = t
    return first


def _rotated(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The columns of ``y`` (m, n) rotated to start at their first maximum and closed with it.

    Returns ``(order, r)``: ``r`` (m + 1, n), C-contiguous, holds in its column i the rotated
    column ``order[i]`` of ``y``. Sorting the columns by the row of their maximum turns the
    rotation into 3 m block copies (no per-element gather jumping between rows).
    """
    m, n = y.shape
    first = _first_max(y)
    order = np.argsort(first, kind="stable")
    ys = np.empty((m, n), dtype=np.float64)
    for t in range(m):
        np.take(y[t], order, out=ys[t])
    bounds = np.searchsorted(first[order], np.arange(m + 1))
    r = np.empty((m + 1, n), dtype=np.float64)
    for s in range(m):
        c0, c1 = bounds[s], bounds[s + 1]
        if c0 == c1:
            continue
        r[: m - s, c0:c1] = ys[s:, c0:c1]
        r[m - s : m, c0:c1] = ys[:s, c0:c1]
        r[m, c0:c1] = ys[s, c0:c1]
    return order, r


def _damage_chunk(
    y: np.ndarray, damage_of: DamageFunction, periodic: bool, stack: np.ndarray
) -> np.ndarray:
    """Damage per load cycle of the columns of ``y`` (m, n), float64 with contiguous rows.

    ``stack`` is work space of at least (m + 1) n floats (reused between chunks).
    """
    order = None
    if periodic:
        order, y = _rotated(y)
    steps, n = y.shape
    cols = np.arange(n)
    # Point j's reversals below ``top`` are stack[k * n + j] for lo[j] <= k < hi[j]. Row hi[j] is
    # scratch: every point writes its top there at every step and keeps it only when it pushes;
    # there are at most steps - 1 pushes, so ``steps`` rows suffice.
    lo = np.zeros(n, dtype=np.intp)
    hi = np.zeros(n, dtype=np.intp)
    top = y[0].copy()  # newest value: the tentative reversal ending the current run
    up = np.zeros(n, dtype=bool)  # the current run rises (meaningful while hi > lo)
    d = np.zeros(n, dtype=np.float64)

    for t in range(1, steps):
        v = y[t]
        dv = v - top  # zero exactly when v == top (finite floats)
        moved = dv != 0.0
        rising = dv > 0.0
        push = moved & ~((hi > lo) & (rising == up))  # a reversal at top, or the first move
        stack[hi * n + cols] = top
        hi += push
        flip = up ^ rising
        flip &= push
        up ^= flip
        np.copyto(top, v)
        # Three-point test on the points whose top moved and that hold >= 3 reversals. Index
        # arrays are narrowed with flatnonzero + take (faster than boolean indexing).
        act = np.flatnonzero(moved & (hi - lo >= 2))
        while act.size:
            h = hi[act]
            row = h * n + act  # the scratch row hi of each point
            p = stack[row - n]  # Y = (q, p), X = (p, top)
            q = stack[row - 2 * n]
            sel = np.flatnonzero(np.abs(top[act] - p) >= np.abs(p - q))  # X >= Y
            if not sel.size:
                break
            act, h = act[sel], h[sel]
            dmg = _damage(damage_of, np.maximum(p[sel], q[sel]))
            if periodic:  # always a full cycle: both points of Y are discarded (lo stays 0)
                d[act] += dmg
                h -= 2
                hi[act] = h
                act = act[np.flatnonzero(h >= 2)]
            else:
                l = lo[act]
                half = h - l == 2  # Y contains the starting point S
                d[act] += dmg * (1.0 - 0.5 * half)
                l += half  # half cycle: S is discarded, the next point becomes S
                h -= 2 * ~half  # full cycle: both points of Y are discarded
                lo[act] = l
                hi[act] = h
                act = act[np.flatnonzero(h - l >= 2)]

    if not periodic:  # residue: each range left counts as a half cycle, oldest first
        act = np.flatnonzero(hi > lo)
        k = 0
        while act.size:
            j = lo[act] + k
            a = stack[j * n + act]
            last = j + 1 == hi[act]
            b = np.where(last, top[act], stack[np.minimum(j + 1, steps - 1) * n + act])
            d[act] += 0.5 * _damage(damage_of, np.maximum(a, b))
            act = act[~last]
            k += 1
    if order is not None:
        out = np.empty_like(d)
        out[order] = d
        return out
    return d


def rainflow_damage(
    series: np.ndarray,
    damage_of: DamageFunction,
    periodic: bool = True,
    *,
    chunk: int | None = None,
) -> np.ndarray:
    """Miner damage per load cycle of many histories by rainflow counting (docs/model.md §4.4).

    Parameters
    ----------
    series
        Shape (m, N): m ≥ 2 time steps of one load cycle (time first) for N points (last);
        converted to C-contiguous float64. Must be finite.
    damage_of
        Vectorised map from an array of equivalent stresses (a cycle's peak) to the damage of one
        cycle at that stress, 1/N(τ), zero for τ ≤ 0; must return an array of the same shape.
        It is called on 1-D contiguous arrays of peaks, several times per call.
    periodic
        True (default, our case): the history repeats every load cycle; it is rotated to start
        at its maximum and closed with it, and all cycles are full cycles (Downing & Socie 1982).
        False: ASTM E1049-85 §5.4.4 three-point counting with half cycles for the residue.
    chunk
        Points per chunk (memory bound); by default chosen from m. It does not change results.

    Returns
    -------
    d : ndarray, shape (N,)
        d = Σ_cycles w_c · damage_of(peak_c) with w_c = 1 (full) or 0.5 (half cycle) and
        **[choice]** peak_c = the larger of the cycle's two extreme values, since a Dang Van-type
        criterion loads a cycle by its maximum of τ̂ + α σ_H. A constant history has no cycle and
        zero damage. A point's value does not depend on the other points (bitwise).
    """
    a = np.asarray(series)
    if a.ndim != 2:
        raise ValueError(
            f"series must have shape (m, N) (time steps, points), got ndim={a.ndim} "
            f"shape {a.shape}"
        )
    m, n = a.shape
    if m < 2:
        raise ValueError(f"a history needs at least 2 time steps, got m={m}")
    a = np.ascontiguousarray(a, dtype=np.float64)
    if not np.isfinite(a).all():
        raise ValueError("series contains NaN or infinite values")
    if chunk is None:
        chunk = max(1, min(_CHUNK_POINTS_MAX, _CHUNK_ENTRIES // (m + 1)))
    elif chunk < 1:
        raise ValueError(f"chunk must be a positive number of points, got {chunk}")
    out = np.zeros(n, dtype=np.float64)
    stack = np.empty((m + 1) * min(n, chunk), dtype=np.float64)
    for c0 in range(0, n, chunk):
        c1 = min(n, c0 + chunk)
        out[c0:c1] = _damage_chunk(a[:, c0:c1], damage_of, periodic, stack)
    return out
