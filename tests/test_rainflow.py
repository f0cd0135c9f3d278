"""Rainflow counting and damage per load cycle (fatigue/rainflow.py, docs/model.md §4.4)."""

from __future__ import annotations

import numpy as np
import pytest

from micropit_hpc.fatigue.rainflow import rainflow_cycles_1d, rainflow_damage, reversals

# ASTM E1049-85 §5.4.4, Fig. 6: the example history, points A..I.
ASTM_HISTORY = [-2.0, 1.0, -3.0, 5.0, -1.0, 3.0, -4.0, 4.0, -2.0]

# Its three-point count, derived by hand from §5.4.4 (X = newest range, Y = the one before it,
# S = starting point), as (range, mean, peak, weight) in counting order:
#   A B C: X=|C-B|=4 >= Y=|B-A|=3, Y holds S=A   -> A-B half (range 3), S := B
#   B C D: X=8 >= Y=4, Y holds S=B               -> B-C half (range 4), S := C
#   C D E: X=6 <  Y=8;  D E F: X=4 < Y=6
#   E F G: X=7 >= Y=|F-E|=4, S not in Y          -> E-F full (range 4), discard E, F
#   C D G: X=9 >= Y=8, Y holds S=C               -> C-D half (range 8), S := D
#   D G H: X=8 < Y=9;  G H I: X=6 < Y=8; end     -> residue D-G, G-H, H-I halves (9, 8, 6)
# Totals: range 3: 0.5, range 4: 1.5, range 6: 0.5, range 8: 1.0, range 9: 0.5 (the standard's
# table for this example; 4 cycles in all).
ASTM_THREE_POINT = [
    (3.0, -0.5, 1.0, 0.5),  # A-B
    (4.0, -1.0, 1.0, 0.5),  # B-C
    (4.0, 1.0, 3.0, 1.0),  # E-F
    (8.0, 1.0, 5.0, 0.5),  # C-D
    (9.0, 0.5, 5.0, 0.5),  # D-G (residue)
    (8.0, 0.0, 4.0, 0.5),  # G-H (residue)
    (6.0, 1.0, 4.0, 0.5),  # H-I (residue)
]
ASTM_RANGE_COUNTS = {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5}

# The same history repeated (periodic): rotated to start at its maximum D=5 and closed with it,
# 5 -1 3 -4 4 -2 -2 1 -3 5, reversals 5 -1 3 -4 4 -2 1 -3 5; every Y with X >= Y is a full cycle:
#   5 -1 3 -4: X=7 >= Y=4 -> (-1, 3) full;  ... -2 1 -3: X=4 >= Y=3 -> (-2, 1) full;
#   5 -4 4 -3 5: X=8 >= Y=7 -> (4, -3) full; then 5 -4 5: X=9 >= Y=9 -> (5, -4) full; left: 5.
ASTM_PERIODIC = [
    (4.0, 1.0, 3.0, 1.0),
    (3.0, -0.5, 1.0, 1.0),
    (7.0, 0.5, 4.0, 1.0),
    (9.0, 0.5, 5.0, 1.0),
]


def sn_damage(tau: np.ndarray) -> np.ndarray:
    """An S-N-like damage 1/N(τ): rises steeply with τ, zero for τ ≤ 0 (docs/model.md §4.4
    shape)."""
    out = np.zeros_like(tau)
    pos = tau > 0
    out[pos] = np.exp(4.0 * tau[pos] - 20.0)
    return out


def ones(tau: np.ndarray) -> np.ndarray:
    return np.ones_like(tau)


def identity(tau: np.ndarray) -> np.ndarray:
    return tau.copy()


def reference_damage(y: np.ndarray, periodic: bool, damage_of=sn_damage) -> float:
    total = 0.0
    for _rng, _mean, peak, weight in rainflow_cycles_1d(y, periodic=periodic):
        total += weight * float(damage_of(np.array([peak]))[0])
    return total


def column(values) -> np.ndarray:
    return np.asarray(values, dtype=float)[:, None]


# --- the ASTM example -------------------------------------------------------------------------


def test_astm_example_three_point_counts():
    cycles = rainflow_cycles_1d(ASTM_HISTORY, periodic=False)
    assert cycles == ASTM_THREE_POINT
    counts: dict[float, float] = {}
    for rng, _mean, _peak, weight in cycles:
        counts[rng] = counts.get(rng, 0.0) + weight
    assert counts == ASTM_RANGE_COUNTS
    assert sum(counts.values()) == 4.0


def test_astm_example_periodic_counts():
    assert rainflow_cycles_1d(ASTM_HISTORY, periodic=True) == ASTM_PERIODIC
    # any rotation of a repeating history is the same history
    rotated = ASTM_HISTORY[5:] + ASTM_HISTORY[:5]
    assert sorted(rainflow_cycles_1d(rotated)) == sorted(ASTM_PERIODIC)


@pytest.mark.parametrize("periodic", [False, True])
def test_astm_example_damage_uses_peaks_and_weights(periodic):
    y = column(ASTM_HISTORY)
    # Σ w: 4 cycles either way (6 halves + 1 full, or 4 full)
    assert rainflow_damage(y, ones, periodic=periodic)[0] == 4.0
    # Σ w·peak: 0.5·(1+1+5+5+4+4) + 3 = 13 (non-periodic), 3+1+4+5 = 13 (periodic); a count
    # by range (Σ w·range = 22 or 23) or by valley would differ.
    assert rainflow_damage(y, identity, periodic=periodic)[0] == 13.0
    expected = sum(w * float(sn_damage(np.array([p]))[0])
                   for _r, _m, p, w in (ASTM_PERIODIC if periodic else ASTM_THREE_POINT))
    assert rainflow_damage(y, sn_damage, periodic=periodic)[0] == pytest.approx(expected, 1e-14)


# --- simple histories -------------------------------------------------------------------------


def test_reversals():
    assert reversals([0, 1, 1, 2, 1, 1, 0, 0, 3]).tolist() == [0, 2, 0, 3]
    assert reversals([2, 2, 2]).tolist() == [2]
    assert reversals([1, 2]).tolist() == [1, 2]
    assert reversals([3, 1, 1, 1]).tolist() == [3, 1]


@pytest.mark.parametrize("m", [3, 4, 7, 20, 64, 201])
def test_sinusoid_is_one_full_cycle_at_its_maximum(m):
    rng = np.random.default_rng(m)
    t = np.arange(m)
    y = 0.3 + 1.7 * np.sin(2 * np.pi * t / m + rng.uniform(0, 2 * np.pi))
    cycles = rainflow_cycles_1d(y, periodic=True)
    assert len(cycles) == 1
    rng_, _mean, peak, weight = cycles[0]
    assert (rng_, peak, weight) == (y.max() - y.min(), y.max(), 1.0)
    assert rainflow_damage(y[:, None], ones)[0] == 1.0
    assert rainflow_damage(y[:, None], identity)[0] == y.max()


@pytest.mark.parametrize("periodic", [False, True])
def test_constant_history_has_no_cycle(periodic):
    y = np.full((17, 3), 2.5)
    assert rainflow_cycles_1d(y[:, 0], periodic=periodic) == []
    assert rainflow_damage(y, ones, periodic=periodic).tolist() == [0.0, 0.0, 0.0]


def test_monotone_history():
    y = np.linspace(-1.0, 3.0, 9)
    # one pass: a half cycle from the first to the last value
    assert rainflow_cycles_1d(y, periodic=False) == [(4.0, 1.0, 3.0, 0.5)]
    assert rainflow_damage(y[:, None], identity, periodic=False)[0] == 1.5
    # repeated: rise then drop back every cycle, one full cycle
    assert rainflow_cycles_1d(y, periodic=True) == [(4.0, 1.0, 3.0, 1.0)]
    assert rainflow_damage(y[::-1, None], identity, periodic=True)[0] == 3.0


def test_two_step_history():
    y = np.array([[1.0, 2.0, -1.0], [3.0, 2.0, -4.0]])
    assert rainflow_damage(y, identity, periodic=False).tolist() == [1.5, 0.0, -0.5]
    assert rainflow_damage(y, identity, periodic=True).tolist() == [3.0, 0.0, -1.0]


# --- vectorised against the sequential reference ------------------------------------------------


def random_batch(rng: np.random.Generator, m: int, n: int) -> np.ndarray:
    """n series of length m of several kinds: noise, integer levels (ties and plateaus),
    constant, monotone, repeated values, sinusoid plus noise."""
    kinds = [
        lambda: rng.standard_normal(m),
        lambda: rng.integers(-2, 3, m).astype(float),
        lambda: np.full(m, rng.standard_normal()),
        lambda: np.sort(rng.standard_normal(m)) * rng.choice([-1.0, 1.0]),
        lambda: np.repeat(rng.integers(-3, 4, m), rng.integers(1, 4))[:m].astype(float),
        lambda: np.sin(2 * np.pi * np.arange(m) / m * rng.integers(1, 4))
        + 0.3 * rng.standard_normal(m),
        lambda: np.cumsum(rng.standard_normal(m)),
    ]
    cols = [kinds[i % len(kinds)]() for i in range(n)]
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("periodic", [False, True])
def test_vectorised_matches_sequential_reference(periodic):
    rng = np.random.default_rng(20240611)
    lengths = [2, 3, 4, 5, 6, 9, 16, 20, 33, 80, 150]
    checked = 0
    for m in lengths:
        n = 190
        y = random_batch(rng, m, n)
        for chunk in (None, 37):
            d = rainflow_damage(y, sn_damage, periodic=periodic, chunk=chunk)
            assert d.shape == (n,)
            for j in range(n):
                ref = reference_damage(y[:, j], periodic)
                if ref == 0.0:
                    assert d[j] == 0.0
                else:
                    assert abs(d[j] - ref) <= 1e-12 * abs(ref), (m, j, d[j], ref)
        checked += n
    assert checked >= 2000


@pytest.mark.parametrize("periodic", [False, True])
def test_cycle_count_matches_reference(periodic):
    # Σ w counted exactly (ones): catches a lost or extra cycle whose damage would be tiny.
    rng = np.random.default_rng(7)
    y = random_batch(rng, 41, 300)
    d = rainflow_damage(y, ones, periodic=periodic)
    for j in range(y.shape[1]):
        assert d[j] == sum(c[3] for c in rainflow_cycles_1d(y[:, j], periodic=periodic))


def test_periodic_counting_is_independent_of_the_phase():
    rng = np.random.default_rng(3)
    y = random_batch(rng, 30, 140)
    d0 = rainflow_damage(y, ones)
    for shift in (1, 7, 29):
        assert np.array_equal(rainflow_damage(np.roll(y, shift, axis=0), ones), d0)


# --- determinism, sign, input handling ----------------------------------------------------------


@pytest.mark.parametrize("periodic", [False, True])
def test_point_result_is_independent_of_the_batch(periodic):
    rng = np.random.default_rng(11)
    y = random_batch(rng, 48, 3000)
    d = rainflow_damage(y, sn_damage, periodic=periodic)
    parts = np.concatenate([rainflow_damage(y[:, a:b], sn_damage, periodic=periodic)
                            for a, b in ((0, 1), (1, 1234), (1234, 2999), (2999, 3000))])
    assert np.array_equal(parts, d)
    for j in (0, 5, 1233, 2999):
        alone = rainflow_damage(y[:, j : j + 1], sn_damage, periodic=periodic)
        assert alone.tobytes() == d[j : j + 1].tobytes()
    for chunk in (1, 17, 1000):
        some = rainflow_damage(y[:, :250] if chunk == 1 else y, sn_damage, periodic=periodic,
                               chunk=chunk)
        assert np.array_equal(some, d[: some.size])
    rev = rainflow_damage(y[:, ::-1], sn_damage, periodic=periodic)
    assert np.array_equal(rev[::-1], d)


@pytest.mark.parametrize("periodic", [False, True])
def test_damage_is_never_negative(periodic):
    rng = np.random.default_rng(5)
    y = 3.0 * random_batch(rng, 25, 2000) - 1.0
    d = rainflow_damage(y, sn_damage, periodic=periodic)
    assert np.all(np.isfinite(d))
    assert np.all(d >= 0.0)
    assert np.any(d > 0.0)


def test_input_forms():
    y = np.array([[0, 2], [3, -1], [-1, 4], [2, 0]])  # integers, converted to float64
    expected = rainflow_damage(y.astype(float), identity)
    assert np.array_equal(rainflow_damage(np.asfortranarray(y), identity), expected)
    assert rainflow_damage(np.zeros((5, 0)), ones).shape == (0,)


def test_invalid_input():
    with pytest.raises(ValueError, match="shape"):
        rainflow_damage(np.arange(5.0), ones)  # 1-D
    with pytest.raises(ValueError, match="shape"):
        rainflow_damage(np.zeros((4, 3, 2)), ones)
    with pytest.raises(ValueError, match="at least 2 time steps"):
        rainflow_damage(np.zeros((1, 6)), ones)
    with pytest.raises(ValueError, match="at least 2 time steps"):
        rainflow_damage(np.zeros((0, 6)), ones)
    with pytest.raises(ValueError, match="NaN"):
        rainflow_damage(np.array([[0.0, 1.0], [np.nan, 0.0]]), ones)
    with pytest.raises(ValueError, match="NaN"):
        rainflow_damage(np.array([[0.0, 1.0], [np.inf, 0.0]]), ones)
    with pytest.raises(ValueError, match="damage_of"):
        rainflow_damage(column(ASTM_HISTORY), lambda tau: np.ones(3))
    with pytest.raises(ValueError, match="chunk"):
        rainflow_damage(column(ASTM_HISTORY), ones, chunk=0)
    with pytest.raises(ValueError, match="1-D"):
        rainflow_cycles_1d(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="at least 2 time steps"):
        rainflow_cycles_1d([1.0])
