"""Dry FFT contact (Polonsky–Keer with a pressure cap) against Hertz and Westergaard."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest
from helpers import E_PRIME, rough_gap

from micropit_hpc.lubrication.dry import ContactError, ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.scene import LubricationSpec
from micropit_hpc.spectral import Grid

#: The scene's solver settings (lubrication.tolerance and max_iterations).
TOL, MAX_ITER = LubricationSpec().tol, LubricationSpec().max_iter

E, NU = 210e9, 0.3
E_STAR = E_PRIME / 2               # Johnson's contact modulus
R = 0.01


def _window(n=256, length=2e-3):
    g = Grid(n, n, length, length)
    X, Y = np.meshgrid(g.x, g.y, indexing="ij")
    return g, X, Y


def test_sphere_against_hertz_256():
    """Johnson eq. 4.22/4.23: a³ = 3PR/(4E*), p0 = 3P/(2πa²). Contact radius a = L/8, so the
    periodic images change the solution by ~(a/L)³ (0.2 %); measured 0.25 % and 0.37 %."""
    g, X, Y = _window()
    a = g.lx / 8
    P = 4 * E_STAR * a**3 / (3 * R)
    p0 = 3 * P / (2 * math.pi * a**2)
    r = solve_dry_contact((X**2 + Y**2) / (2 * R), ElasticHalfSpaces(g, E_PRIME), P / g.lx**2,
                          tol=TOL, max_iter=MAX_ITER)
    a_num = math.sqrt(np.count_nonzero(r.contact) * g.dx * g.dy / math.pi)
    assert r.pressure.max() == pytest.approx(p0, rel=0.01)
    assert a_num == pytest.approx(a, rel=0.01)
    assert r.pressure.mean() == pytest.approx(P / g.lx**2, rel=1e-10)


def test_cylinder_against_hertz_256():
    """Johnson eq. 4.43/4.45: b² = 4wR/(πE*), p0 = 2w/(πb). Half-width b = L/16: the periodic
    row of cylinders shifts p0 and b by ~(b/L)² (0.3 %; 1.3 % at b = L/8, 0.05 % at L/32).
    Width from the pressure's second moment, ∫p x² / ∫p = b²/4 for Hertz; and from the count of
    contact points to within one grid spacing."""
    g, X, _ = _window()
    b = g.lx / 16
    w = math.pi * E_STAR * b**2 / (4 * R)
    p0 = 2 * w / (math.pi * b)
    r = solve_dry_contact(X**2 / (2 * R), ElasticHalfSpaces(g, E_PRIME), w / g.lx, tol=TOL,
                          max_iter=MAX_ITER)
    row = r.pressure[:, 0]
    b_moment = 2 * math.sqrt((row * g.x**2).sum() / row.sum())
    assert r.pressure.max() == pytest.approx(p0, rel=0.01)
    assert b_moment == pytest.approx(b, rel=0.01)
    assert abs(np.count_nonzero(row) * g.dx - 2 * b) <= 1.01 * g.dx
    assert np.ptp(r.pressure, axis=1).max() < 1e-9 * p0   # uniform along the cylinder


def _westergaard(n=256):
    lam = 1e-3
    g = Grid(n, 4, lam, lam / n * 4)
    delta = 1e-6
    gap0 = np.broadcast_to((delta * (1 - np.cos(2 * np.pi * g.x / lam)))[:, None], g.shape)
    p_star = math.pi * E_STAR * delta / lam          # Johnson eq. 13.9: full contact from p*
    return g, lam, gap0.copy(), p_star


def test_westergaard_full_contact():
    """Above p* the surfaces touch everywhere and p = p̄ + p* cos(2πx/λ) exactly."""
    g, lam, gap0, p_star = _westergaard()
    p_mean = 1.5 * p_star
    r = solve_dry_contact(gap0, ElasticHalfSpaces(g, E_PRIME), p_mean, tol=1e-12, max_iter=MAX_ITER)
    exact = p_mean + p_star * np.cos(2 * np.pi * g.x / lam)
    assert np.abs(r.pressure[:, 0] - exact).max() < 1e-9 * p_star
    assert r.area_fraction == 1.0
    assert np.abs(r.gap).max() < 1e-9 * 1e-6


def test_westergaard_partial_contact():
    """Below p*: sin²(πa/λ) = p̄/p* and p(x) = 2p̄ cos(πx/λ) √(sin²(πa/λ) − sin²(πx/λ)) /
    sin²(πa/λ) (Johnson eq. 13.12–13.14)."""
    g, lam, gap0, p_star = _westergaard(512)
    p_mean = 0.3 * p_star
    r = solve_dry_contact(gap0, ElasticHalfSpaces(g, E_PRIME), p_mean, tol=TOL, max_iter=MAX_ITER)
    a = lam / math.pi * math.asin(math.sqrt(p_mean / p_star))
    s2a = math.sin(math.pi * a / lam) ** 2
    x = g.x
    exact = np.where(np.abs(x) < a, 2 * p_mean * np.cos(np.pi * x / lam) / s2a * np.sqrt(
        np.clip(s2a - np.sin(np.pi * x / lam) ** 2, 0, None)), 0.0)
    row = r.pressure[:, 0]
    assert abs(np.count_nonzero(row) * g.dx - 2 * a) <= 1.01 * g.dx   # contact area
    assert row.max() == pytest.approx(exact.max(), rel=5e-3)
    assert np.abs(row - exact).max() < 0.05 * exact.max()             # edge cells: √ profile
    assert row.mean() == pytest.approx(p_mean, rel=1e-10)


def test_pressure_cap_and_load_balance():
    """With p_lim below the elastic peak the cap holds, the mean is the load to 1e-10, and the
    complementarity conditions hold: g ≥ 0 off contact, g = 0 on elastic contact, g ≤ 0 where
    the material yielded."""
    g, gap0 = rough_gap()
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    elastic = solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER)
    p_lim = 0.5 * elastic.pressure.max()
    r = solve_dry_contact(gap0, hs, P, p_lim=p_lim, tol=TOL, max_iter=MAX_ITER)
    assert r.pressure.max() <= p_lim
    assert r.pressure.min() >= 0.0
    assert r.pressure.mean() == pytest.approx(P, rel=1e-10)
    plastic = r.pressure >= p_lim
    free = r.pressure == 0.0
    on = ~plastic & ~free
    scale = gap0.std()
    assert plastic.any() and on.any()
    assert r.gap[free].min() >= -1e-6 * scale
    assert np.abs(r.gap[on]).max() <= 1e-5 * scale
    assert r.gap[plastic].max() <= 1e-6 * scale
    assert r.area_fraction > elastic.area_fraction     # yielding spreads the load


@pytest.mark.parametrize("case", ["elastic", "capped", "capped warm", "held free"])
def test_the_gap_and_the_approach_are_those_of_the_pressure(case):
    """g = g0 + u(p) − δ at every point, δ the returned approach, to round-off: the solver takes
    δ from its last CG step's mean contact gap and the yielded points' displacement from a
    field made once per yielded set, not from a convolution of the final pressure. Checked
    against u(p) made here from the answer, on a contact with no point at the cap, one with
    about a tenth of the window at the cap (cold and warm) and one with columns held free."""
    g, gap0 = rough_gap(4)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    elastic = solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER)
    p_lim = math.inf if case == "elastic" else 0.45 * elastic.pressure.max()
    kw = {}
    if case == "capped warm":
        kw["p_init"] = solve_dry_contact(gap0 + 1e-8 * np.sin(g.x)[:, None], hs, P, p_lim,
                                         tol=TOL, max_iter=MAX_ITER).pressure
    if case == "held free":
        kw["free"] = np.zeros(g.shape, bool)
        kw["free"][::7, ::5] = True
    r = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, **kw)
    if case != "elastic":
        assert np.count_nonzero(r.pressure >= p_lim) > 0.02 * r.pressure.size
    u = hs.displacement(r.pressure)
    misfit = gap0 + u - r.gap - r.approach
    # every term is at most a few times max|g0| + max|u|; the CG's gap sums its pieces (g0,
    # the yielded points' u, the others' c·u) in another order than this check
    bound = 64 * np.finfo(float).eps * (np.abs(gap0).max() + np.abs(u).max())
    assert np.abs(misfit).max() <= bound


def test_every_contact_point_touches_to_the_solves_accuracy():
    """DryContact.gap_accuracy: every point that carries pressure has a gap at or below it,
    and it is far below the roughness (100 residuals of the solve). The raw gap of an elastic
    contact point is the solve's residual, of either sign (here some are positive: the case
    the accuracy exists for), so "gap ≤ 0" alone would put such points out of contact."""
    g, gap0 = rough_gap(4)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    for cap in (p_lim, math.inf):
        r = solve_dry_contact(gap0, hs, P, cap, tol=TOL, max_iter=MAX_ITER)
        on = r.pressure > 0
        assert np.count_nonzero(on & (r.pressure < cap) & (r.gap > 0)) > 0
        assert 0.0 < r.gap_accuracy <= 1e-5 * gap0.std()
        assert np.all(r.gap[on] <= r.gap_accuracy)
    assert solve_dry_contact(gap0, hs, 0.0, tol=TOL, max_iter=MAX_ITER).gap_accuracy == 0.0


def test_a_yielded_set_that_holds_is_not_convolved_again(monkeypatch):
    """The field g0 + u(p_lim on the yielded points) is made once per yielded set: a rung or an
    early update that leaves the set as it was reuses it (one convolution saved each; a cold
    capped solve and a warm one)."""
    g, gap0 = rough_gap(4)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    seen = []
    orig = hs.displacement

    def displacement(p):
        seen.append(p.copy())
        return orig(p)

    monkeypatch.setattr(hs, "displacement", displacement)
    cold = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, coarsest=0)
    for start in (None, cold.pressure):
        seen.clear()
        solve_dry_contact(gap0 + 1e-8, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER,
                          p_init=start, coarsest=0)
        yielded = [f > 0.0 for f in seen]       # the fields of the yielded points (0 or p_lim)
        assert len(yielded) >= 1
        assert all(np.all((f == 0.0) | (f == p_lim)) for f in seen)
        assert not any(np.array_equal(a, b) for a, b in pairwise(yielded))


def test_warm_start_gives_the_same_answer_faster():
    g, gap0 = rough_gap(5)
    hs = ElasticHalfSpaces(g, E_PRIME)
    cold = solve_dry_contact(gap0, hs, 0.8e9, tol=1e-10, max_iter=MAX_ITER)
    warm = solve_dry_contact(gap0, hs, 0.8e9, tol=1e-10, max_iter=MAX_ITER,
                             p_init=cold.pressure)
    assert warm.iterations < cold.iterations
    assert np.abs(warm.pressure - cold.pressure).max() < 1e-6 * cold.pressure.max()


def test_zero_load_touches_and_flat_surfaces_carry_uniform_pressure():
    g, gap0 = rough_gap()
    hs = ElasticHalfSpaces(g, E_PRIME)
    r = solve_dry_contact(gap0 + 3e-7, hs, 0.0, tol=TOL, max_iter=MAX_ITER)
    assert r.gap.min() == 0.0 and not r.contact.any()
    flat = solve_dry_contact(np.full(g.shape, 2e-7), hs, 1e9, tol=TOL, max_iter=MAX_ITER)
    assert np.all(flat.pressure == 1e9)


def test_errors_are_clear():
    g, gap0 = rough_gap()
    hs = ElasticHalfSpaces(g, E_PRIME)
    with pytest.raises(ContactError, match=r"did not converge.*after 3 iterations"):
        solve_dry_contact(gap0, hs, 1e9, tol=TOL, max_iter=3)
    with pytest.raises(ContactError, match="whole window would yield"):
        solve_dry_contact(gap0, hs, 5e9, p_lim=4.2e9, tol=TOL, max_iter=MAX_ITER)
    with pytest.raises(ContactError, match="finite"):
        solve_dry_contact(gap0, hs, math.nan, tol=TOL, max_iter=MAX_ITER)


@pytest.mark.parametrize("seed", [3, 8])
def test_inexact_set_search_finds_the_same_answer(seed, monkeypatch):
    """The yielded set sought with √tol solves first (dry.LOOSE_UPDATES) ends on the answer of
    the search at the full tolerance throughout: the same yielded set, pressures within 1e-7
    of the cap, and the load and the cap held exactly."""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(seed)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    fast = solve_dry_contact(gap0, hs, P, p_lim=p_lim, tol=1e-10, max_iter=MAX_ITER)
    monkeypatch.setattr(dry, "LOOSE_UPDATES", 0)
    exact = solve_dry_contact(gap0, hs, P, p_lim=p_lim, tol=1e-10, max_iter=MAX_ITER)
    assert np.array_equal(fast.pressure >= p_lim, exact.pressure >= p_lim)
    assert np.abs(fast.pressure - exact.pressure).max() <= 1e-7 * p_lim
    for r in (fast, exact):
        assert r.pressure.max() <= p_lim and r.pressure.mean() == pytest.approx(P, rel=1e-12)


# ---- the coarse-to-fine start and the stopping rule (issue 31) --------------------------------

def test_restriction_keeps_the_mean_and_prolongation_keeps_bounds_and_caps():
    """Full weighting keeps the mean (to the rounding bound of the sums); bilinear
    prolongation reproduces constants and the coarse values exactly, stays within the coarse
    field's bounds, and between two capped points is the cap itself (a mean of equal values)."""
    from micropit_hpc.lubrication.dry import prolong, restrict

    g, gap0 = rough_gap(4)
    c = restrict(gap0)
    assert c.shape == (g.nx // 2, g.ny // 2)
    bound = 8 * np.finfo(float).eps * np.abs(gap0).sum() / gap0.size
    assert abs(c.mean() - gap0.mean()) <= bound
    p_lim = 2.5e9
    pc = np.clip(c / c.max() * 3e9, 0.0, p_lim)
    pc[:10, :10] = p_lim
    f = prolong(pc)
    assert f.shape == gap0.shape
    assert np.array_equal(f[::2, ::2], pc)
    assert f.min() >= pc.min() and f.max() <= pc.max()
    assert np.all(f[:19, :19] == p_lim)
    assert np.all(prolong(np.full((4, 6), 1.7)) == 1.7)


def test_coarse_levels_halve_even_grids_down_to_the_coarsest():
    from micropit_hpc.lubrication.dry import coarse_levels

    assert coarse_levels(Grid(1024, 1024, 1, 1), 64) == 4
    assert coarse_levels(Grid(256, 96, 1, 1), 32) == 1      # 96 → 48 → 24 < 32
    assert coarse_levels(Grid(250, 250, 1, 1), 64) == 1     # 125 is odd
    assert coarse_levels(Grid(127, 128, 1, 1), 8) == 0
    assert coarse_levels(Grid(1024, 1024, 1, 1), 0) == 0


@pytest.mark.parametrize("seed", [3, 8])
def test_coarse_to_fine_start_gives_the_single_level_answer_in_fewer_fine_iterations(
        seed, monkeypatch):
    """A rough contact with a large yielded set (p_lim 0.45 of the elastic peak, ~9 % of the
    window at the cap): the cold solve started from the 64² solution (the default) and the
    single-level solve (coarsest = 0) end on the same yielded set, pressures within 1e-7 p_lim
    (both meet the conditions at tol = 1e-10: the criterion of the inexact set search above),
    the load held exactly; and the started solve takes fewer iterations on the 128² grid.
    The early updates of the yielded set are off here: on this 128² grid they alone bring the
    single-level solve to the started one's fine iterations (the next test), and the coarse
    start's own saving is what this test holds."""
    from micropit_hpc.lubrication import dry

    monkeypatch.setattr(dry, "EARLY_UPDATE_ITERATIONS", 0)
    g, gap0 = rough_gap(seed)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    single = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, coarsest=0)
    multi = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER)
    assert single.coarse_iterations == 0 and multi.coarse_iterations > 0
    assert np.array_equal(multi.pressure >= p_lim, single.pressure >= p_lim)
    assert np.abs(multi.pressure - single.pressure).max() <= 1e-7 * p_lim
    assert multi.pressure.max() <= p_lim and multi.pressure.mean() == pytest.approx(P, rel=1e-12)
    assert multi.iterations - multi.coarse_iterations < single.iterations


@pytest.mark.parametrize("seed", [3, 8])
def test_early_updates_of_the_yielded_set_find_the_same_answer_in_fewer_iterations(
        seed, monkeypatch):
    """dry.EARLY_UPDATE_ITERATIONS: a cold single-level solve whose yielded set is updated
    every 3 CG iterations while it changes ends on the answer of the search with full
    inexact solves (the same yielded set, pressures within 1e-7 p_lim: both meet the
    conditions at tol = 1e-10), the load and the cap held, in under 0.6 of its iterations
    (about 0.4 measured on these surfaces, 9–10 % of the window at the cap)."""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(seed)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    early = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, coarsest=0)
    monkeypatch.setattr(dry, "EARLY_UPDATE_ITERATIONS", 0)
    full = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, coarsest=0)
    assert np.array_equal(early.pressure >= p_lim, full.pressure >= p_lim)
    assert np.abs(early.pressure - full.pressure).max() <= 1e-7 * p_lim
    assert early.pressure.max() <= p_lim and early.pressure.mean() == pytest.approx(P, rel=1e-12)
    assert early.iterations < 0.6 * full.iterations


def test_a_rung_between_the_loose_and_the_full_tolerance_saves_iterations(monkeypatch):
    """dry.COLD_RUNGS: a cold solve started from the coarse-to-fine start's pressure seeks its
    yielded set at √tol, then at tol^(3/4), then at tol, where one rung went from √tol
    straight to tol. The same yielded set and pressures as close to a tight reference, in
    fewer iterations (0.85 of them over three 256² surfaces, 9–14 % of the window at the cap,
    at the scene's tolerance)."""
    from micropit_hpc.lubrication import dry

    ladder, single = 0, 0
    for seed in (1, 2, 3):
        g, gap0 = rough_gap(seed, 256)
        hs = ElasticHalfSpaces(g, E_PRIME)
        P = 1.0e9
        p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
        ref = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-12, max_iter=MAX_ITER).pressure
        monkeypatch.setattr(dry, "COLD_RUNGS", 2)
        two = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
        monkeypatch.setattr(dry, "COLD_RUNGS", 1)
        one = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
        assert np.array_equal(two.pressure >= p_lim, one.pressure >= p_lim)
        assert np.array_equal(two.pressure >= p_lim, ref >= p_lim)
        err_two = np.linalg.norm(two.pressure - ref) / np.linalg.norm(ref)
        err_one = np.linalg.norm(one.pressure - ref) / np.linalg.norm(ref)
        assert err_two <= max(2 * err_one, 1e-7)
        assert two.pressure.max() <= p_lim
        assert two.pressure.mean() == pytest.approx(P, rel=1e-12)
        ladder, single = ladder + two.iterations, single + one.iterations
    assert ladder < 0.95 * single


def test_an_elastic_contact_climbs_no_second_rung(monkeypatch):
    """With no point at the cap there is no yielded set to seek: a cold solve goes from √tol
    straight to tol whatever dry.COLD_RUNGS, bit for bit (a second rung only split its CG,
    and the restarted CG, from a pressure already near tol, moved the answer by 2e-12 between
    one rank and two where one CG moved it by 4e-14: tests/test_contact_mpi.py)."""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(3, 256)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 2.0 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    two = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
    monkeypatch.setattr(dry, "COLD_RUNGS", 1)
    one = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
    assert two.coarse_iterations > 0 and two.pressure.max() < p_lim
    assert two.iterations == one.iterations
    assert np.array_equal(two.pressure, one.pressure)


def test_a_warm_solve_makes_no_early_updates(monkeypatch):
    """A warm start (p_init given) is already near its yielded set: its search keeps the full
    inexact solves, so its answer does not depend on dry.EARLY_UPDATE_ITERATIONS at all."""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(3)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    start = solve_dry_contact(gap0, hs, 0.9 * P, p_lim, tol=TOL, max_iter=MAX_ITER).pressure
    warm = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, p_init=start)
    monkeypatch.setattr(dry, "EARLY_UPDATE_ITERATIONS", 0)
    same = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, p_init=start)
    assert warm.iterations == same.iterations
    assert np.array_equal(warm.pressure, same.pressure)


def test_the_stiffness_response_inverts_the_response():
    """ElasticHalfSpaces.stiffness_response (the preconditioner's S = E'κ/4 per mode) applied
    to the displacement of a pressure gives that pressure less its mean, to round-off, on a
    window that is not square."""
    g = Grid(96, 80, 3e-4, 2.5e-4)
    rng = np.random.default_rng(5)
    p = rng.random(g.shape) * 1e9
    hs = ElasticHalfSpaces(g, E_PRIME)
    u = hs.displacement(p)
    back = hs.stiffness_response(u)
    assert np.abs(back - (p - p.mean())).max() <= 1e-12 * p.max()


@pytest.mark.parametrize("p_lim_share", [0.45, math.inf])
def test_the_preconditioned_cg_finds_the_same_answer_in_fewer_iterations(p_lim_share,
                                                                         monkeypatch):
    """dry.PRECONDITION: the CG preconditioned by the inverse response (after the first rung
    of the yielded set's search, and once the contact set holds) ends on the same yielded set
    as the plain CG, its pressure no farther from a tight reference, in fewer iterations
    (0.77 of them with 9–14 % of the window at the cap, 0.67–0.73 elastic, over three 256²
    surfaces at the scene's tolerance; 0.85 required)."""
    from micropit_hpc.lubrication import dry

    pre_its = plain_its = 0
    for seed in (1, 2, 3):
        g, gap0 = rough_gap(seed, 256)
        hs = ElasticHalfSpaces(g, E_PRIME)
        P = 1.0e9
        p_lim = p_lim_share * solve_dry_contact(gap0, hs, P, tol=TOL,
                                                max_iter=MAX_ITER).pressure.max()
        ref = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-12, max_iter=MAX_ITER).pressure
        monkeypatch.setattr(dry, "PRECONDITION", True)
        pre = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
        monkeypatch.setattr(dry, "PRECONDITION", False)
        plain = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
        assert np.array_equal(pre.pressure >= p_lim, ref >= p_lim)
        assert np.array_equal(plain.pressure >= p_lim, ref >= p_lim)
        err_pre = np.linalg.norm(pre.pressure - ref) / np.linalg.norm(ref)
        err_plain = np.linalg.norm(plain.pressure - ref) / np.linalg.norm(ref)
        assert err_pre <= err_plain
        assert pre.error <= TOL and pre.pressure.max() <= p_lim
        assert pre.pressure.mean() == pytest.approx(P, rel=1e-12)
        pre_its, plain_its = pre_its + pre.iterations, plain_its + plain.iterations
    assert pre_its < 0.85 * plain_its


def test_a_loose_solve_is_not_preconditioned(monkeypatch):
    """Every phase of a solve looser than dry.PRECONDITION_TOL runs the plain CG (there the
    preconditioned pressures made the yielded set flip at every update): a 1e-4 solve is the
    same bit for bit with the preconditioner switched on or off."""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(3)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    p_lim = 0.45 * solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    assert dry.PRECONDITION_TOL < 1e-4
    monkeypatch.setattr(dry, "PRECONDITION", True)
    on = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-4, max_iter=MAX_ITER)
    monkeypatch.setattr(dry, "PRECONDITION", False)
    off = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-4, max_iter=MAX_ITER)
    assert on.iterations == off.iterations
    assert np.array_equal(on.pressure, off.pressure)


def test_a_failed_solve_reports_the_iterations_it_spent():
    """A solve stopped by max_iterations says so, with the iterations it spent, a coarse
    level's included (at 10 the 64² level fails after its 5, half the budget, and the fine
    solve from uniform pressure takes the other 5)."""
    g, gap0 = rough_gap(3)
    hs = ElasticHalfSpaces(g, E_PRIME)
    for budget in (10, 30):
        with pytest.raises(ContactError, match=f"after {budget} iterations") as e:
            solve_dry_contact(gap0, hs, 1.0e9, 2.5e9, tol=TOL, max_iter=budget)
        assert e.value.iterations == budget


def test_a_point_on_the_edge_of_the_yielded_set_leaves_it_at_most_once():
    """The paper gear's position 2 at 512², step 20, cold at φ = 1: on the 256² level of the
    coarse-to-fine start one point left the yielded set and came back at every update (its gap
    open by 1.24 residuals at the cap, its pressure one ulp above the cap without it), 4925
    one-iteration updates until max_iterations, 12 s for a 1-s solve. At the full tolerance a
    point now leaves the set at most once. Round-off decides whether a CPU meets this point;
    where it does not, the solve takes its ordinary ~150 iterations either way."""
    from dataclasses import replace

    from helpers import SCENES

    from micropit_hpc.cycle import PositionCycle
    from micropit_hpc.plan import make_plan
    from micropit_hpc.scene import load_scene

    base = load_scene(str(SCENES / "paper_gear_z23.toml"))
    scene = replace(base, window=replace(base.window, nx=512, ny=None))
    plan = make_plan(scene, positions=[2], life=False)
    cycle = PositionCycle(plan.study, 2, window=plan.window)
    hs = ElasticHalfSpaces(cycle.grid, cycle.study.E_prime)
    P = cycle.mean_pressure(cycle.centre(cycle.time(20)))
    sol = solve_dry_contact(cycle.rough_gap(20), hs, P, cycle.p_lim, tol=TOL, max_iter=MAX_ITER)
    assert sol.iterations < 1000
    assert sol.pressure.max() <= cycle.p_lim
    assert sol.pressure.mean() == pytest.approx(P, rel=1e-12)


def test_a_finer_grid_is_held_to_a_proportionally_smaller_residual(monkeypatch):
    """The stopping rule (dry.residual_threshold): ε ≤ tol on grids up to 256 points along
    the longer side, ε ≤ tol·(256/n)^0.4 beyond; a solve stops at that threshold;
    TOLERANCE_POINTS = 0 restores ε ≤ tol everywhere."""
    from micropit_hpc.lubrication import dry

    assert dry.residual_threshold(1e-8, Grid(128, 128, 1, 1)) == 1e-8
    tight = 1e-8 * 0.25**0.4
    assert dry.residual_threshold(1e-8, Grid(1024, 256, 1, 1)) == pytest.approx(tight)
    g, lam, gap0, p_star = _westergaard(1024)
    hs = ElasticHalfSpaces(g, E_PRIME)
    r = solve_dry_contact(gap0, hs, 0.3 * p_star, tol=1e-8, max_iter=MAX_ITER)
    assert r.error <= tight
    monkeypatch.setattr(dry, "TOLERANCE_POINTS", 0)
    loose = solve_dry_contact(gap0, hs, 0.3 * p_star, tol=1e-8, max_iter=MAX_ITER)
    # the same iteration from the same start, stopped at the first ε ≤ 1e-8
    assert loose.error <= 1e-8 and loose.iterations <= r.iterations
    assert loose.iterations < r.iterations or loose.error <= tight


@pytest.mark.parametrize("p_lim_share", [math.inf, 0.45])
def test_directions_kept_conjugate_through_entries_give_the_reset_answer(p_lim_share,
                                                                         monkeypatch):
    """dry.RESET_ON_ENTRY = False (the default) keeps the CG directions conjugate when points
    enter the contact; Polonsky & Keer's restart (True) is the reference. Both end on the same
    answer: the same yielded set and pressures within 1e-7 of the peak at tol = 1e-10 (the
    criterion of the inexact set search above), the load exact. (Fewer iterations on large
    rough windows, where the restarts made the count grow with the grid, but not on every
    small smooth one: that is measured in docs/performance.md, not asserted here.)"""
    from micropit_hpc.lubrication import dry

    g, gap0 = rough_gap(6)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    peak = solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER).pressure.max()
    p_lim = p_lim_share * peak
    kept = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, coarsest=0)
    monkeypatch.setattr(dry, "RESET_ON_ENTRY", True)
    reset = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, coarsest=0)
    assert np.array_equal(kept.pressure >= p_lim, reset.pressure >= p_lim)
    assert np.abs(kept.pressure - reset.pressure).max() <= 1e-7 * peak
    assert kept.pressure.mean() == pytest.approx(P, rel=1e-12)
    assert kept.pressure.max() <= p_lim


# ---- points held free: open micropits (life.pit_contact = "open") -----------------------------
def _conditions_hold(r, gap0, P, p_lim, free):
    """Load, cap, zero pressure on the free points and complementarity on the others."""
    scale = gap0.std()
    assert np.all(r.pressure[free] == 0.0)
    assert r.pressure.mean() == pytest.approx(P, rel=1e-10)
    assert r.pressure.min() >= 0.0 and r.pressure.max() <= p_lim
    plastic = r.pressure >= p_lim
    off = (r.pressure == 0.0) & ~free
    on = ~plastic & ~off & ~free
    assert on.any()
    assert r.gap[off].min() >= -1e-6 * scale
    assert np.abs(r.gap[on]).max() <= 1e-5 * scale
    if plastic.any():
        assert r.gap[plastic].max() <= 1e-6 * scale


@pytest.mark.parametrize("p_lim_share", [math.inf, 0.6])
def test_points_held_free_carry_nothing_and_their_load_settles_on_the_rest(p_lim_share):
    """The most loaded 5 % of the points held free (open pits): they carry no pressure, the
    load, the cap and the complementarity conditions hold on the others, and the counterface
    comes down onto more of the other points than touched before."""
    g, gap0 = rough_gap(7)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 1.0e9
    plain = solve_dry_contact(gap0, hs, P, tol=TOL, max_iter=MAX_ITER)
    p_lim = p_lim_share * plain.pressure.max()
    if math.isfinite(p_lim):
        plain = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
    free = plain.pressure >= np.quantile(plain.pressure, 0.95)
    r = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, free=free)
    _conditions_hold(r, gap0, P, p_lim, free)
    intact_before = np.count_nonzero((plain.pressure > 0.0) & ~free)
    assert np.count_nonzero(r.pressure > 0.0) > intact_before
    assert r.gap[free].min() < 0.0        # the held points would touch: nothing holds them up


def test_points_held_free_out_of_contact_change_nothing():
    """Holding free points that are out of contact anyway gives the same solution (to the
    solver's tolerance), cold (the mask restricted onto the coarse levels) and warm."""
    g, gap0 = rough_gap(8)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P = 0.8e9
    plain = solve_dry_contact(gap0, hs, P, 2.5e9, tol=1e-10, max_iter=MAX_ITER)
    rng = np.random.default_rng(1)
    free = (plain.gap > 0.05 * gap0.std()) & (rng.random(g.shape) < 0.7)
    assert free.mean() > 0.3
    for start in (None, plain.pressure):
        r = solve_dry_contact(gap0, hs, P, 2.5e9, tol=1e-10, max_iter=MAX_ITER,
                              p_init=start, free=free)
        assert np.abs(r.pressure - plain.pressure).max() <= 1e-6 * plain.pressure.max()


def test_a_warm_start_that_loads_the_held_points_is_set_free():
    """A warm start from before the pits (the held points at the cap, which would keep them in
    the yielded set) ends where the cold solve ends."""
    g, gap0 = rough_gap(9)
    hs = ElasticHalfSpaces(g, E_PRIME)
    P, p_lim = 1.0e9, 2.0e9
    plain = solve_dry_contact(gap0, hs, P, p_lim, tol=TOL, max_iter=MAX_ITER)
    free = plain.pressure >= p_lim
    assert free.sum() > 10
    cold = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER, free=free)
    warm = solve_dry_contact(gap0, hs, P, p_lim, tol=1e-10, max_iter=MAX_ITER,
                             p_init=plain.pressure, free=free)
    _conditions_hold(warm, gap0, P, p_lim, free)
    assert np.abs(warm.pressure - cold.pressure).max() <= 1e-6 * cold.pressure.max()


def test_a_load_the_points_not_held_cannot_carry_is_refused():
    g, gap0 = rough_gap(3, 32)
    hs = ElasticHalfSpaces(g, E_PRIME)
    free = np.ones(g.shape, bool)
    free[:4, :4] = False
    with pytest.raises(ContactError, match="not held free would reach the cap"):
        solve_dry_contact(gap0, hs, 1.0e9, 3.0e9, tol=TOL, max_iter=MAX_ITER, free=free)
    with pytest.raises(ValueError, match="free shape"):
        solve_dry_contact(gap0, hs, 1.0e9, 3.0e9, tol=TOL, max_iter=MAX_ITER, free=free[1:])


def test_a_solve_whose_directions_cycle_restarts_them_and_converges():
    """A 64² step of the paper gear (position 5) with 62 % of the window in open pits: the
    yielded set takes nearly all the load and leaves three points in the elastic contact, where
    the directions kept conjugate through entries cycled without end (the residual stuck at
    1e-3 until max_iterations); the stall rule (dry.STALL_ITERATIONS) restarts them and the
    solve meets every condition. The gap and mask are stored in tests/data."""
    from pathlib import Path

    d = np.load(Path(__file__).parent / "data" / "open_pits_stall_64.npz")
    lx, ly = d["lengths"]
    g = Grid(*d["gap0"].shape, float(lx), float(ly))
    hs = ElasticHalfSpaces(g, float(d["E_prime"]))
    P, p_lim, free = float(d["P"]), float(d["p_lim"]), d["free"]
    r = solve_dry_contact(d["gap0"], hs, P, p_lim, tol=TOL, max_iter=MAX_ITER, free=free)
    _conditions_hold(r, d["gap0"], P, p_lim, free)
    assert np.count_nonzero(r.pressure >= p_lim) > 50
