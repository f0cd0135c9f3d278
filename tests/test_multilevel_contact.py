"""The coarse-to-fine start in the mixed model's dry solves (issue 31): the same solutions as
the single-level solves, with the start taken."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import E_PRIME, SOLVER, mixed_model, random_pair

from micropit_hpc.lubrication import dry, mixed, rheology
from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.spectral import rfft_plan


def _solve(h_mean, monkeypatch, coarsest):
    """The mixed solution on a 128² pair with the dry solves' coarse start down to
    ``coarsest`` points (0: none), and the coarse iterations of its dry solves."""
    g, (z1, z2) = random_pair(128)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    coarse = []

    def counted(*args, **kwargs):
        sol = solve_dry_contact(*args, **kwargs)
        coarse.append(sol.coarse_iterations)
        return sol

    monkeypatch.setattr(dry, "COARSEST", coarsest)
    monkeypatch.setattr(mixed, "solve_dry_contact", counted)
    return g, (z1, z2), mixed_model(g, h_mean=h_mean).solve(r, r, 1.0e9, 5e-5), sum(coarse)


def test_vanishing_film_with_the_coarse_start_gives_the_dry_solution(monkeypatch):
    """h̄ → 0 on 128² (φ = 1): the mixed model's dry solves start coarse to fine and end on the
    single-level dry solution of the same roughness (the bound of test_mixed's limit)."""
    g, (z1, z2), sol, coarse = _solve(1e-12, monkeypatch, 64)
    ref = solve_dry_contact(-(z1 + z2), ElasticHalfSpaces(g, E_PRIME), 1.0e9, p_lim=4.2e9,
                            coarsest=0, **SOLVER)
    assert sol.phi == 1.0 and coarse > 0
    assert np.abs(sol.pressure - ref.pressure).max() < 1e-6 * ref.pressure.max()
    assert np.abs(sol.clearance - ref.gap).max() < 1e-6 * z1.std()


def test_intermediate_film_with_the_coarse_start_balances_the_flow_as_before(monkeypatch):
    """An intermediate film on 128²: with and without the coarse start the flow balance
    holds to the film tolerance's bound of test_mixed, and the two solutions agree."""
    h = 0.35e-6
    _, _, multi, coarse = _solve(h, monkeypatch, 64)
    _, _, single, none = _solve(h, monkeypatch, 0)
    assert coarse > 0 and none == 0
    for sol in (multi, single):
        assert 0.0 < sol.phi < 1.0
        c_rho = rheology.density_correction(sol.phi * 1.0e9)
        assert sol.film_mean == pytest.approx(c_rho * h, rel=2e-4)
        assert sol.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    # the same trial loads (the film values differ by the dry solves' tolerance only), so the
    # same root, and pressures within the bound of the dry solves of test_mixed
    assert multi.phi == pytest.approx(single.phi, rel=1e-6)
    assert np.abs(multi.pressure - single.pressure).max() < 1e-6 * single.pressure.max()


def _fine_solves(model) -> list[float]:
    """The trial fractions of the last solve's film balances made on the window itself
    (the loaded ones: φ = 0 needs no contact solve)."""
    return [phi for phi, levels, _ in model.last_scan if levels == 0 and phi > 0]


@pytest.mark.parametrize("h_mean", [1e-12, 0.1e-6, 0.35e-6])
def test_the_coarse_phi_scan_gives_the_plain_scans_root_and_pressures(h_mean, monkeypatch):
    """On 256² (the φ scan on 128², then only its bracket on the window): the same load
    fraction and pressures as the scan made on the window at every trial, where the root is
    φ = 1 (one loaded solve on the window instead of four), between two trials of the scan
    (0.25 < φ < 0.5) and below the first (φ < 0.25)."""
    g, (z1, z2) = random_pair(256)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    monkeypatch.setattr(mixed, "SCAN_LEVELS", 0)
    plain_model = mixed_model(g, h_mean=h_mean)
    plain = plain_model.solve(r, r, 1.0e9, 5e-5)
    monkeypatch.setattr(mixed, "SCAN_LEVELS", 3)
    model = mixed_model(g, h_mean=h_mean)
    sol = model.solve(r, r, 1.0e9, 5e-5)
    assert model._scan_grid()[0] == 1                   # 256² → 128² (SCAN_POINTS)
    assert any(levels == 1 for _, levels, _ in model.last_scan)
    assert not any(levels for _, levels, _ in plain_model.last_scan)
    assert sol.phi == pytest.approx(plain.phi, rel=1e-9)
    assert np.abs(sol.pressure - plain.pressure).max() < 1e-6 * plain.pressure.max()
    assert np.abs(sol.clearance - plain.clearance).max() < 1e-6 * z1.std()
    assert sol.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    if h_mean == 1e-12:
        assert sol.phi == 1.0
        assert _fine_solves(plain_model) == list(mixed.PHI_SCAN)
        assert _fine_solves(model) == [1.0]
    else:
        c_rho = rheology.density_correction(sol.phi * 1.0e9)
        assert sol.film_mean == pytest.approx(c_rho * h_mean, rel=2e-4)
        assert (0.25 < sol.phi < 0.5) if h_mean == 0.1e-6 else (0.0 < sol.phi < 0.25)
        # the bracket's two ends are solved on the window as in the plain scan: no more
        assert len(_fine_solves(model)) <= len(_fine_solves(plain_model))


@pytest.mark.parametrize("case", ["root later than coarse", "root earlier than coarse",
                                  "coarse misses the root"])
def test_a_coarse_scan_that_puts_the_root_elsewhere_is_corrected_on_the_window(case,
                                                                                monkeypatch):
    """The coarse scan's signs are only a guide: where they are wrong on the window (given
    here by a coarse scan that lies), the trials are followed on the window until the plain
    scan's bracket is found: the same root and pressures as the plain scan."""
    g, (z1, z2) = random_pair()
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    h_mean, lie = {
        # on the window f(0.25) > 0 > f(0.5); the coarse scan claims f(0.25) ≤ 0
        "root later than coarse": (0.1e-6, [(0.25, -1e-12)]),
        # on the window f(0.25) < 0; the coarse scan claims it far above the film
        "root earlier than coarse": (0.35e-6, [(0.25, 1.0), (0.5, -1e-12)]),
        # on the window f(0.25) < 0; the coarse scan claims no root at all, near f = 0
        "coarse misses the root": (0.35e-6, [(t, 1e-12) for t in mixed.PHI_SCAN]),
    }[case]
    monkeypatch.setattr(mixed, "SCAN_LEVELS", 0)
    plain = mixed_model(g, h_mean=h_mean).solve(r, r, 1.0e9, 5e-5)
    model = mixed_model(g, h_mean=h_mean)
    monkeypatch.setattr(model, "_coarse_scan", lambda *args: list(lie))
    sol = model.solve(r, r, 1.0e9, 5e-5)
    assert 0.0 < plain.phi < 1.0
    assert sol.phi == pytest.approx(plain.phi, rel=1e-9)
    assert np.abs(sol.pressure - plain.pressure).max() < 1e-6 * plain.pressure.max()


def test_a_failing_coarse_scan_falls_back_to_the_scan_on_the_window(monkeypatch):
    """A coarse solve of the φ scan that fails (ContactError) leaves the scan to the window:
    the plain scan's answer, every trial on the window."""
    g, (z1, z2) = random_pair(256)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    monkeypatch.setattr(mixed, "SCAN_LEVELS", 0)
    plain = mixed_model(g, h_mean=1e-12).solve(r, r, 1.0e9, 5e-5)
    monkeypatch.setattr(mixed, "SCAN_LEVELS", 3)

    def failing_on_coarse(gap0, hs, *args, **kwargs):
        if hs.grid.nx < g.nx:
            raise dry.ContactError("coarse solve failed (test)")
        return solve_dry_contact(gap0, hs, *args, **kwargs)

    monkeypatch.setattr(mixed, "solve_dry_contact", failing_on_coarse)
    model = mixed_model(g, h_mean=1e-12)
    sol = model.solve(r, r, 1.0e9, 5e-5)
    assert _fine_solves(model) == list(mixed.PHI_SCAN)
    assert sol.phi == plain.phi == 1.0
    assert np.array_equal(sol.pressure, plain.pressure)


def _counted_solves(monkeypatch) -> list:
    """The mixed model's dry solves, recorded as (load, tolerance) in the list returned, from
    here to the end of the test."""
    solves = []

    def counted(*args, **kwargs):
        sol = solve_dry_contact(*args, **kwargs)
        solves.append((args[2], kwargs["tol"]))
        return sol

    monkeypatch.setattr(mixed, "solve_dry_contact", counted)
    return solves


def _scan_solve(h_mean, monkeypatch, tolerance, margin=mixed.SCAN_SIGN_MARGIN):
    """The mixed solution on the 128² pair (the scan on the window) with the scan's trials
    below φ = 1 solved to ``tolerance`` (None: the scene's) and the sign margin ``margin``:
    (solution, the dry solves made as (load, tolerance), the film balances of its scan, R_q of
    the first surface)."""
    g, (z1, z2) = random_pair(128)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    monkeypatch.setattr(mixed, "SCAN_TOLERANCE", tolerance)
    monkeypatch.setattr(mixed, "SCAN_SIGN_MARGIN", margin)
    solves = _counted_solves(monkeypatch)
    model = mixed_model(g, h_mean=h_mean)
    sol = model.solve(r, r, 1.0e9, 5e-5)
    return sol, solves, model.last_scan, z1.std()


@pytest.mark.parametrize("h_mean", [1e-12, 0.1e-6, 0.35e-6])
def test_the_scans_loose_trials_give_the_tight_scans_answer(h_mean, monkeypatch):
    """The scan's trials below φ = 1 solved to SCAN_TOLERANCE: the same bracket, and the
    answer (the root search's, or the trial φ = 1 itself) within the scene's tolerance of the
    scan made at the scene's tolerance, where the root is φ = 1, between two trials and below
    the first; the trials at the loose tolerance, the answer's solves at the scene's."""
    tight, tight_solves, tight_scan, rq = _scan_solve(h_mean, monkeypatch, None)
    loose, loose_solves, loose_scan, _ = _scan_solve(h_mean, monkeypatch, 1e-3)
    tol = SOLVER["tol"]
    assert all(t == tol for _, t in tight_solves)
    trials = [(p, t) for p, t in loose_solves if 0.0 < p < 1.0e9 and t != tol]
    assert trials and all(t == 1e-3 for _, t in trials)
    # the same trials, each with the sign of the tight scan's balance
    scan = [(phi, f) for phi, _, f in loose_scan if phi in mixed.PHI_SCAN]
    ref = [(phi, f) for phi, _, f in tight_scan if phi in mixed.PHI_SCAN]
    assert [phi for phi, _ in scan] == [phi for phi, _ in ref]
    assert all((f > 0) == (f_ref > 0) for (_, f), (_, f_ref) in zip(scan, ref, strict=True))
    # both root searches stop within the film tolerance (1e-4 h̄) of the balance: their φ and
    # pressures agree to that order (measured: 2e-6 and 3e-6 of the largest pressure)
    assert loose.phi == pytest.approx(tight.phi, rel=1e-4)
    assert np.abs(loose.pressure - tight.pressure).max() < 1e-4 * tight.pressure.max()
    assert loose.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    if h_mean == 1e-12:         # the answer is the trial φ = 1, at the scene's tolerance
        assert loose.phi == tight.phi == 1.0
        assert loose_solves[-1] == (1.0e9, tol)
        assert np.abs(loose.pressure - tight.pressure).max() < 1e-6 * tight.pressure.max()
        assert np.abs(loose.clearance - tight.clearance).max() < 1e-6 * rq
    else:
        c_rho = rheology.density_correction(loose.phi * 1.0e9)
        assert loose.film_mean == pytest.approx(c_rho * h_mean, rel=2e-4)
    assert loose.iterations < tight.iterations


def test_a_loose_trial_near_the_film_is_solved_again_at_the_scenes_tolerance(monkeypatch):
    """A trial whose balance is within the margin of the loose solve's error is solved again
    at the scene's tolerance (with a margin that takes every trial: each one twice)."""
    sol, solves, _, _ = _scan_solve(1e-12, monkeypatch, 1e-3, margin=1e12)
    loads = [p for p, _ in solves if 0.0 < p < 1.0e9]
    assert loads and all(loads.count(p) == 2 for p in set(loads))
    tol = SOLVER["tol"]
    for p in set(loads):
        assert [t for q, t in solves if q == p] == [1e-3, tol]
    assert sol.phi == 1.0


def test_a_loose_trial_that_fails_is_solved_at_the_scenes_tolerance(monkeypatch):
    """A loose trial's solve that does not converge in SCAN_MAX_ITERATIONS (here 1, so every
    one fails) is made at the scene's tolerance from the same start: the tight scan's answer
    bit for bit, where the root lies between two trials."""
    tight, tight_solves, _, _ = _scan_solve(0.1e-6, monkeypatch, None)
    monkeypatch.setattr(mixed, "SCAN_MAX_ITERATIONS", 1)
    loose, loose_solves, _, _ = _scan_solve(0.1e-6, monkeypatch, 1e-3)
    assert loose_solves == tight_solves         # the failed loose solves raised: not counted
    assert loose.phi == tight.phi
    assert np.array_equal(loose.pressure, tight.pressure)


@pytest.mark.parametrize("p_lim", [np.inf, 2.0e9])
def test_the_contact_is_order_preserving_as_the_certified_scan_assumes(p_lim):
    """The two properties :meth:`~micropit_hpc.lubrication.mixed.MixedLubrication.
    _certified_scan` builds on, on random gaps, elastic and with yielded points: at a fixed
    load the approach of g0 + e lies within [min e, max e] of g0's, and the signed mean gap
    ⟨g0⟩ − δ does not fall when the load does (measured on these cases: the shift at least
    0.37 of the range of e from either end, the mean gap 39–123 nm larger at half the load;
    283–1119 of the 4096 points yielded in the capped ones)."""
    g, (z1, z2) = random_pair(64)
    hs = ElasticHalfSpaces(g, E_PRIME)
    _, (e1, e2) = random_pair(64, seed=11)
    for z, e, P in ((z1, 0.5 * e1, 0.8e9), (z2, 0.3 * e2, 1.2e9), (z1 + z2, e1 - e2, 1.0e9)):
        a = solve_dry_contact(z, hs, P, p_lim, tol=1e-10, max_iter=5000)
        b = solve_dry_contact(z + e, hs, P, p_lim, tol=1e-10, max_iter=5000)
        c = solve_dry_contact(z, hs, 0.5 * P, p_lim, tol=1e-10, max_iter=5000)
        shift = b.approach - a.approach
        assert e.min() < shift < e.max()
        assert c.gap.mean() > a.gap.mean()
        # the signed mean gap is ⟨g0⟩ − δ (the displacement has no mean)
        assert a.gap.mean() == pytest.approx(z.mean() - a.approach, abs=1e-12 * z.std())
        if np.isfinite(p_lim):
            assert (a.pressure >= p_lim).any()      # the capped case has yielded points


def _certified_pair(h_mean, scales, certify, monkeypatch):
    """The 128² pair's mixed solutions of one step evaluated once per scale of its surfaces in
    ``scales``, one warm dict throughout, with the certified scan on or off: (the last
    solution, its dry solves as (load, tolerance), its scan's film balances)."""
    g, (z1, z2) = random_pair(128)
    fft = rfft_plan(g.shape)
    monkeypatch.setattr(mixed, "SCAN_CERTIFY", certify)
    solves = _counted_solves(monkeypatch)
    model, warm = mixed_model(g, h_mean=h_mean), {}
    for scale in scales:
        r = (fft.forward(-scale * z1), fft.forward(-scale * z2))
        del solves[:]
        sol = model.solve(r, r, 1.0e9, 5e-5, warm=warm)
    return sol, list(solves), model.last_scan


@pytest.mark.parametrize("scale, proved", [(1.0, False), (3.0, True), (10.0, True)])
def test_the_certified_scan_gives_the_plain_scans_answer_with_fewer_solves(scale, proved,
                                                                          monkeypatch):
    """Where the last evaluation found no root (φ = 1), the scan starts at φ = 1 and skips
    the trials it proves above the film: the same answer bit for bit (the solve at φ = 1
    starts from the same warm pressure), with fewer dry solves where a trial is proved (the
    pair three and ten times as rough; as rough as it is, f(1) = 0.04 µm is too close to the
    film for any proof, and every trial is solved); the trials it solves have the plain
    scan's signs."""
    plain, plain_solves, plain_scan = _certified_pair(1e-12, (scale, scale), False,
                                                      monkeypatch)
    cert, cert_solves, cert_scan = _certified_pair(1e-12, (scale, scale), True, monkeypatch)
    assert plain.phi == cert.phi == 1.0
    assert np.array_equal(cert.pressure, plain.pressure)
    assert np.array_equal(cert.clearance, plain.clearance)
    assert len(cert_solves) < len(plain_solves) if proved else \
        sorted(cert_solves) == sorted(plain_solves)
    assert cert_solves[1] == (1.0e9, SOLVER["tol"])     # after the one at no load: φ = 1
    ref = {phi: f for phi, _, f in plain_scan}
    assert all(f > 0 and ref[phi] > 0 for phi, _, f in cert_scan if phi in mixed.PHI_SCAN)


@pytest.mark.parametrize("h_mean", [0.1e-6, 0.35e-6])
def test_a_root_after_a_step_without_one_is_found_by_the_certified_scan(h_mean, monkeypatch):
    """An evaluation without a root (the surfaces three times as rough), then one with a root
    between two trials or below the first: the certified scan, started at φ = 1 (below the
    film here, so it proves nothing), finds the plain scan's bracket and root, and the next
    evaluation scans from φ = 0.25 again."""
    plain, _, plain_scan = _certified_pair(h_mean, (3.0, 1.0), False, monkeypatch)
    cert, solves, cert_scan = _certified_pair(h_mean, (3.0, 1.0), True, monkeypatch)
    assert plain.phi < 1.0
    assert solves[1] == (1.0e9, SOLVER["tol"])
    # the trials and the root search start from the same pressures as the plain scan's
    # (the first evaluation's, kept in the warm dict): the same answer bit for bit
    assert cert.phi == plain.phi
    assert np.array_equal(cert.pressure, plain.pressure)
    # the bracket: the smallest trial with f <= 0 in both
    first = [min(phi for phi, _, f in scan if phi in mixed.PHI_SCAN and f <= 0)
             for scan in (plain_scan, cert_scan)]
    assert first[0] == first[1]
    _, again, _ = _certified_pair(h_mean, (3.0, 1.0, 1.0), True, monkeypatch)
    assert again[1][0] == 0.25e9


class _FakeFilm:
    """A film balance f(φ) given as a table, for :meth:`MixedLubrication._certified_scan`
    alone: each call records its φ and returns (f, a stand-in solution naming φ)."""

    def __init__(self, table):
        self.table, self.calls = table, []

    def __call__(self, phi, near=None):
        self.calls.append(phi)
        return self.table[phi], f"solution at {phi}"


@pytest.mark.parametrize("table, bound_1, spread, calls, answer", [
    # every trial proved from φ = 1: one solve, no root
    ({1.0: 2.0}, 1.9, 1.0, [1.0], (1.0, 2.0, None)),
    # the bound reaches down to 0.75 and 0.5 only: 0.25 is solved (positive): no root
    ({1.0: 2.0, 0.25: 0.5}, 0.7, 1.0, [1.0, 0.25], (1.0, 2.0, None)),
    # 0.25 unproved and below the film: the root lies below the first trial
    ({1.0: 2.0, 0.25: -0.1}, 0.7, 1.0, [1.0, 0.25], (0.0, "f0", 0.25)),
    # nothing proved, 0.5 below the film: the bracket [0.25, 0.5] as the plain scan's
    ({1.0: 2.0, 0.25: 0.3, 0.5: -0.2}, 0.1, 1.0, [1.0, 0.25, 0.5], (0.25, 0.3, 0.5)),
    # φ = 1 below the film, the trials below it proved by nothing (a negative bound): each
    # solved in order, 0.75 the first root
    ({1.0: -0.5, 0.25: 0.4, 0.5: 0.2, 0.75: -0.1}, -0.6, 1.0, [1.0, 0.25, 0.5, 0.75],
     (0.5, 0.2, 0.75)),
])
def test_the_certified_scan_skips_only_what_its_bound_proves(table, bound_1, spread, calls,
                                                             answer):
    """The certified scan on a tabulated balance: the trials it solves, and the bracket it
    returns (lo, f(lo), hi), as the plain scan would from the same signs; a trial is skipped
    where bound(1) − (1 − φ)·spread > 0 (the solve at φ = 1 writes bound(1), which is never
    above f(1): the signed mean gap is at most the open one). So the trials it skips are the
    top ones, and the lower end of a bracket is always a solved trial (or φ = 0)."""
    film = _FakeFilm(table)
    bound = {}
    orig = film.__call__

    def solved(phi, near=None):
        out = orig(phi, near)
        if phi == 1.0:
            bound[1.0] = bound_1
        return out

    lo, flo, _, hi, fhi, sol = mixed.MixedLubrication._certified_scan(solved, "f0", bound,
                                                                      spread)
    assert film.calls == calls
    assert (lo, flo, hi) == answer
    if hi is None:
        assert sol == "solution at 1.0"
    else:
        assert fhi == table[hi] and sol == f"solution at {hi}"

