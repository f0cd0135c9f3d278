"""Backward-Euler wear (micropit_hpc.implicit_wear, docs/life.md "Implicit wear"): the solver
against closed forms of stiff linear wear, and the worn profile of a smooth surface against a
flat converging with the grid and polishing."""

import dataclasses
import itertools
import math

import numpy as np
import pytest

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.implicit_wear import SpectralRelief, backward_euler, next_length
from micropit_hpc.life import initial_state, rms_slope, run_block
from micropit_hpc.lubrication.dry import ContactError
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.surfaces import Topography
from micropit_hpc.wear import WearRate, solid_weight


def _linear(a: np.ndarray, J: np.ndarray):
    """Wear rates Δh(w) = a − J w of two bodies of two points each (J couples all four: a
    worn spot relieves its neighbour and the counterface), as WearRates."""
    def rates(w):
        x = a - J @ np.concatenate([np.ravel(v) for v in w])
        return tuple(WearRate(solid=x[k:k + 2].copy(), fluid=np.zeros(2), relax=np.zeros(2))
                     for k in (0, 2))
    return rates


@pytest.mark.parametrize("stiffness", [1e-3, 1.0, 30.0, 1e3])
def test_backward_euler_solves_stiff_linear_wear(stiffness):
    """w = n(a − J w) ⇔ (I + nJ) w = n a, for n‖J‖ from 1e-3 (explicit would do) to 1e3
    (explicit diverges): the solve meets its tolerance and equals the linear solution."""
    rng = np.random.default_rng(3)
    B = rng.normal(size=(4, 4))
    J = B @ B.T + 0.5 * np.eye(4)
    J *= stiffness / np.linalg.norm(J, 2)
    a = rng.uniform(1e-12, 3e-12, 4)
    n = 1.0
    rates = _linear(a, J)
    start = rates((np.zeros(2), np.zeros(2)))
    tol = 1e-20
    sol = backward_euler(rates, start, n, tol)
    exact = np.linalg.solve(np.eye(4) + n * J, n * a)
    assert sol.converged and sol.residual <= tol
    got = np.concatenate(sol.depth)
    # the residual bound: |w − w*| ≤ ‖(I + nJ)⁻¹‖ · max residual · √4
    assert np.abs(got - exact).max() <= 2.0 * tol + 1e-9 * exact.max()
    if stiffness > 2:
        # the plain fixed point w ← n Δh(w) diverges here
        assert np.abs(n * (a - J @ (n * a))).max() > np.abs(n * a).max()


def test_backward_euler_error_estimate_is_the_local_error_of_a_slow_decay():
    """For dw/dN = a − λw, backward Euler's local error against the exact
    a/λ (1 − e^{−λn}) is (λn²a/2)(1 + O(λn)); the estimate (n/2)|Δh(w) − Δh(0)| gives it."""
    lam, a = 1e-6, np.array([2e-12, 1e-12])

    def rates(w):
        return tuple(WearRate(solid=a - lam * d, fluid=np.zeros(2), relax=np.zeros(2))
                     for d in w)
    start = rates((np.zeros(2), np.zeros(2)))
    for n in (1e3, 1e4):
        sol = backward_euler(rates, start, n, 1e-24)
        exact = a / lam * -np.expm1(-lam * n)
        true = np.abs(sol.depth[0] - exact)
        # the estimate is the shape part (less the mean over the columns): two points
        est = sol.error([np.ones(2, bool), np.ones(2, bool)])[0]
        assert est == pytest.approx(0.5 * abs(true[0] - true[1]), rel=0.05, abs=0)


def test_the_mean_wear_of_a_loosely_solved_step_is_exact():
    """Rates that a uniform wear leaves unchanged, Δh(w) = a − J (w − ⟨w⟩) per body (as the
    contact's: a uniform removal changes nothing it sees): a solve stopped at a third of the
    explicit step's shape residual still removes exactly n ⟨Δh(w)⟩ per body (the mean part is
    solved, not iterated), and the shape residual it reports meets the tolerance."""
    rng = np.random.default_rng(7)
    m = 32
    B = rng.normal(size=(m, m))
    J = B @ B.T / m + 0.2 * np.eye(m)
    P = np.eye(m) - 1.0 / m                           # w − ⟨w⟩
    a = [rng.uniform(1e-12, 3e-12, m), rng.uniform(0.5e-12, 1e-12, m)]
    n = 2.0                                           # n ‖J‖ ≈ 7: stiff

    def rates(w):
        return tuple(WearRate(solid=ak - J @ (P @ wk), fluid=np.zeros(m), relax=np.zeros(m))
                     for ak, wk in zip(a, w, strict=True))
    start = rates((np.zeros(m), np.zeros(m)))
    tol = min(np.abs(n * (ak - ak.mean())).max() for ak in a) / 3
    sol = backward_euler(rates, start, n, tol, invariant=True)
    assert sol.converged and sol.residual <= tol and sol.iterations >= 2
    for d, r in zip(sol.depth, sol.rate_end, strict=True):
        assert d.mean() == pytest.approx(n * r.rate.mean(), rel=1e-12, abs=0)
        assert np.abs(n * r.rate - d).max() <= tol * (1 + 1e-12)
    # the plain residual, mean and all, leaves the mean as inexact as the tolerance lets it
    plain = backward_euler(rates, start, n, tol)
    assert plain.converged
    assert plain.depth[0].mean() != pytest.approx(n * plain.rate_end[0].rate.mean(), rel=1e-6,
                                                  abs=0)


@pytest.mark.parametrize("model", ["dry", "mixed"])
def test_a_uniform_wear_changes_no_rate(model):
    """The premise of the exact mean: the contact-only cycle's wear rates on surfaces worn by
    w and by w + c (a constant per body) agree to rounding, dry and in mixed lubrication."""
    from micropit_hpc.life import _worn, contact_surfaces

    doc = _wave_doc(64, 2e-12, "implicit")
    if model == "mixed":
        del doc["lubrication"], doc["film"]              # the scene's default film model
    scene = scene_from_dict(doc, "wave.toml")
    cyc = _wave_cycle(scene, 2e-12)
    g = cyc.grid
    state = initial_state(cyc)
    surf, pits = contact_surfaces(state, g, scene.life.pit_contact)
    w = (np.random.default_rng(1).uniform(0, 2e-8, g.shape), np.zeros(g.shape))
    before = cyc.wear_rates(_worn(surf, state, w), pits, {})
    after = cyc.wear_rates(_worn(surf, state, (w[0] + 3e-7, w[1] + 1e-7)), pits, {})
    for r0, r1 in zip(before, after, strict=True):
        assert r0.rate.max() > 0
        assert np.abs(r1.rate - r0.rate).max() <= 1e-12 * np.abs(r0.rate).max()


def test_no_wear_solves_no_contact():
    calls = []

    def rates(w):
        calls.append(w)
        return ()
    zero = WearRate(np.zeros(3), np.zeros(3), np.zeros(3))
    sol = backward_euler(rates, (zero, zero), 1e6, 1e-9)
    assert sol.converged and not calls and sol.iterations == len(calls)
    assert all(not d.any() for d in sol.depth)


def _relief_problem(shape=(16, 12), n=1.0):
    """Rates of the spectral relief model itself, Δh(w) = a − √D S √D w per body with D ∝ the
    share of solid contact (a patch), Ŝ = κ (SpectralRelief's inputs), and θ = 1."""
    nx, ny = shape
    kx = 2 * np.pi * np.fft.fftfreq(nx)[:, None]
    ky = 2 * np.pi * np.fft.rfftfreq(ny)[None, :]
    stiff = np.sqrt(kx**2 + ky**2) * 1e3
    K0 = 2.0
    rng = np.random.default_rng(5)
    relax = np.zeros(shape)
    relax[3:11, 2:9] = rng.uniform(0.2, 1.0, (8, 7)) / K0      # D = relax K0
    d = np.sqrt(relax * K0)
    a = rng.uniform(1e-12, 3e-12, shape) * (relax > 0)

    def op(w):
        return d * np.fft.irfft2(stiff * np.fft.rfft2(d * w), s=shape)

    def rates(w):
        return tuple(WearRate(solid=a - op(v), fluid=np.zeros(shape), relax=relax) for v in w)
    return SpectralRelief(stiff, K0, shape, share=1.0), rates, op, a


def test_spectral_relief_inverts_its_own_model():
    """M z = b for M = I + n √D S √D: the preconditioner's conjugate gradients meet their
    tolerance, leave a field outside solid contact (D = 0) as it is, and a body without any
    solid contact untouched."""
    relief, rates, op, a = _relief_problem()
    start = rates((np.zeros_like(a), np.zeros_like(a)))
    n = 50.0
    b = np.random.default_rng(1).normal(size=a.shape)
    z = relief.solve(start, n)((b, b))[0]
    Mz = z + n * op(z)
    assert np.linalg.norm(Mz - b) <= 1.1e-3 * np.linalg.norm(b)
    outside = start[0].relax == 0
    # outside the patch √D = 0: M z = z there
    np.testing.assert_allclose(z[outside], b[outside], rtol=0, atol=1e-12)
    dry = WearRate(np.zeros(a.shape), np.zeros(a.shape), np.zeros(a.shape))
    assert relief.solve((dry, dry), n)((b, b))[1] is b


def test_preconditioned_solve_converges_where_the_plain_one_stalls():
    """On wear whose relief is the preconditioner's own model (n‖S‖ ≈ 4e4, a stiff step), the
    preconditioned Anderson iteration converges in a few contact cycles; the plain one spends
    many more, and both reach the same depth."""
    relief, rates, _, a = _relief_problem()
    start = rates((np.zeros_like(a), np.zeros_like(a)))
    n, tol = 30.0, 1e-14
    pre = backward_euler(rates, start, n, tol, max_iter=60, relief=relief)
    plain = backward_euler(rates, start, n, tol, max_iter=60)
    assert pre.converged and pre.iterations <= 4
    assert plain.iterations > 3 * pre.iterations
    if plain.converged:
        np.testing.assert_allclose(plain.depth[0], pre.depth[0], rtol=0, atol=10 * tol)


def test_the_guess_is_the_first_iterate():
    """A guess that is the solution (as the last step's depth, scaled, nearly is after the
    running-in) is checked by one contact cycle and returned; from the explicit step the same
    solve takes several. A guess whose contact fails is skipped."""
    relief, rates, _, a = _relief_problem()
    start = rates((np.zeros_like(a), np.zeros_like(a)))
    n, tol = 30.0, 1e-14
    exact = backward_euler(rates, start, n, 1e-4 * tol, max_iter=200, relief=relief)
    pre = SpectralRelief(relief.stiffness, relief.K0, relief.shape)     # the default θ
    cold = backward_euler(rates, start, n, tol, max_iter=200, relief=pre)
    warm = backward_euler(rates, start, n, tol, max_iter=200, relief=pre, guess=exact.depth)
    assert cold.converged and cold.iterations > 2
    # one cycle on any CPU: the guess's residual is about 1e-4 tol, far from the tolerance
    assert warm.converged and warm.iterations == 1
    np.testing.assert_allclose(warm.depth[0], cold.depth[0], rtol=0, atol=10 * tol)
    calls = []

    def flaky(w):
        calls.append(w)
        if len(calls) == 1:
            raise ContactError("the guess's contact fails")
        return rates(w)
    sol = backward_euler(flaky, start, n, tol, max_iter=200, relief=pre, guess=exact.depth,
                         errors=(ContactError,))
    assert sol.converged and sol.iterations == cold.iterations + 1


def test_next_length_grows_and_shrinks_within_bounds():
    assert next_length(100.0, 0.0, 1.0) == 400.0
    assert next_length(100.0, 1.0, 1.0) == pytest.approx(90.0)
    assert next_length(100.0, 4.0, 1.0) == pytest.approx(45.0)
    assert next_length(100.0, 1e6, 1.0) == 20.0
    assert next_length(100.0, 1e-6, 1.0) == 400.0


def test_solid_weight_is_the_step_without_a_ramp_and_continuous_with_one():
    h = np.array([-1e-7, 0.0, 5e-8, 1e-7, 2e-7])
    np.testing.assert_array_equal(solid_weight(h, 0.0, 0.0), [1, 1, 0, 0, 0])
    np.testing.assert_allclose(solid_weight(h, 0.0, 1e-7), [1, 1, 0.5, 0, 0])


# ---- a smooth surface worn against a flat --------------------------------------------------
PERIOD = 200e-6       # one period of the sinusoid in x [m]


def _wave_doc(n: int, k_lub: float, integration: str) -> dict:
    return {
        "study": {"name": "wave"},
        "disc": {"p0_GPa": 1.0, "u_mean_m_s": 2.0, "slide_roll": [0.3],
                 "radius1_x_mm": 10.0, "radius2_x_mm": 10.0},
        "body1": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.3,
                  "surface": {"acf": "gaussian", "corr_x_um": 40.0}},
        "body2": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.0},
        "lubricant": {"eta0_mPas": 10.0, "alpha_pv_1_per_GPa": 14.0, "eyring_stress_MPa": 5.0},
        "film": {"hc_um": 0.05},
        "lubrication": {"model": "dry"},
        "window": {"n": n, "ny": 4, "length_x_um": PERIOD * 1e6, "length_y_um": 40.0,
                   "steps": 8},
        "stress": {"layers": 3},
        # no fatigue: the profile is worn, never pitted
        "fatigue": {"woehler_B_MPa": 1e5},
        "wear": {"k_lub_s": [k_lub]},
        "life": {"cycles_M": 0.2, "block_M": 0.1, "wear_integration": integration},
    }


def _wave_cycle(scene, k_lub: float) -> PositionCycle:
    """The load cycle of :func:`_wave_doc`'s scene with body 1 a cosine of amplitude 0.4 µm
    along x (one period per window) and body 2 flat."""
    study = contact_study(scene)
    g = PositionCycle(study, 1, k_lub=k_lub).grid
    x = (np.arange(g.nx) + 0.5) * g.dx
    h1 = 0.4e-6 * np.cos(2 * math.pi * x / PERIOD)[:, None] * np.ones((1, g.ny))
    return PositionCycle(study, 1, k_lub=k_lub, surfaces=(
        Topography(h1, g.dx, g.dy, "cosine"), Topography(np.zeros(g.shape), g.dx, g.dy, "flat")))


def _worn_wave(n: int, integration: str = "implicit", blocks: int = 2,
               k_lub: float = 2e-12) -> tuple[np.ndarray, list[float], float]:
    """Body 1 a cosine of amplitude 0.4 µm along x (one period per window), body 2 flat, worn
    dry at p̄ = 1 GPa: the profile of body 1 after ``blocks`` blocks, and its RMS slope after
    each."""
    scene = scene_from_dict(_wave_doc(n, k_lub, integration), "wave.toml")
    cyc = _wave_cycle(scene, k_lub)
    g = cyc.grid
    state = initial_state(cyc)
    slopes = [rms_slope(state.bodies[0].heights, g.dx)]
    for _ in range(blocks):
        run_block(cyc, state, scene.life)
        slopes.append(rms_slope(state.bodies[0].heights, g.dx))
    return state.bodies[0].heights[:, 0].copy(), slopes, g.dx


def _on(profile: np.ndarray, m: int) -> np.ndarray:
    """A periodic cell-centred profile averaged onto m cells (m divides its length)."""
    return profile.reshape(m, -1).mean(axis=1)


def test_a_worn_cosine_converges_with_the_grid_and_polishes():
    """64 → 128 → 256 cells per period, same physical size: the worn profiles (compared on 64
    cells) agree to 2 % of the crest's wear (the contact solver's tolerance sets the floor of
    their differences, about 1 nm of 229), the crest wear of the finest two within 10 %, and
    every block lowers the slope."""
    profiles, wear = {}, {}
    for n in (64, 128, 256):
        prof, slopes, _ = _worn_wave(n)
        assert all(b < a for a, b in itertools.pairwise(slopes)), slopes
        h0 = 0.4e-6 * np.cos(2 * math.pi * (np.arange(n) + 0.5) / n)
        profiles[n] = _on(prof, 64)
        wear[n] = float((h0 - prof).max())
    d1 = np.abs(profiles[128] - profiles[64]).max()
    d2 = np.abs(profiles[256] - profiles[128]).max()
    assert wear[256] > 0.1e-6                        # the crest wore a quarter of its height
    assert max(d1, d2) < 0.02 * wear[256]
    assert wear[256] == pytest.approx(wear[128], rel=0.1)


def _spied_wave(monkeypatch, n: int, forecast: bool | None = None):
    """The wave of :func:`_worn_wave` (one block; ``life.SHAPE_FORECAST`` = ``forecast``,
    None: the default) and every implicit wear solve of it, in order: its length, first
    iterate, solution and whether the step was accepted."""
    from micropit_hpc import life

    calls, solve, length = [], backward_euler, next_length      # (the module's own, unspied)

    def spy_solve(rates, start, n, tol, **kw):
        sol = solve(rates, start, n, tol, **kw)
        calls.append({"n": n, "guess": kw.get("guess"), "sol": sol, "accepted": False})
        return sol

    def spy_length(n, error, tol, grow=4.0, shrink=0.2):
        if grow != 1.0:             # called on an accepted step only (1.0: an accuracy cut)
            calls[-1]["accepted"] = True
        return length(n, error, tol, grow, shrink)
    monkeypatch.setattr(life, "backward_euler", spy_solve)
    monkeypatch.setattr(life, "next_length", spy_length)
    if forecast is not None:
        monkeypatch.setattr(life, "SHAPE_FORECAST", forecast)
    profile, _, _ = _worn_wave(n, blocks=1)
    return profile, calls


def test_a_step_cut_at_the_shape_limit_restarts_from_its_own_depth(monkeypatch):
    """A converged step that would change the shape by more than the sub-block's limit is
    cut shorter; the shorter step's first iterate is the cut step's worn depth scaled to its
    length (the solution of the same sub-block a little further on), not the last accepted
    step's. Seen from the calls, with the forecast below off so that the wave's running-in
    has such a cut: every solve that follows a cut starts from that guess, bit for bit."""
    _, calls = _spied_wave(monkeypatch, 64, forecast=False)
    cuts = [(a, b) for a, b in itertools.pairwise(calls)
            if not a["accepted"] and a["sol"].converged]
    assert cuts, [(c["n"], c["accepted"]) for c in calls]
    for a, b in cuts:
        assert b["n"] < a["n"] and b["guess"] is not None
        for g, w in zip(b["guess"], a["sol"].depth, strict=True):
            assert np.array_equal(g, (b["n"] / a["n"]) * w)


def test_a_step_foretold_past_the_shape_limit_is_cut_before_it_is_solved(monkeypatch):
    """With ``life.SHAPE_FORECAST`` (the default) no converged solve of the wave is thrown
    away, where without it one is, and the worn profiles agree to 2 % of the crest's wear,
    the band in which the grids agree (test_a_worn_cosine_converges_with_the_grid_and_polishes):
    the forecast moves where sub-blocks end, by less than the wear's accuracy control."""
    n = 64
    foretold, calls = _spied_wave(monkeypatch, n)
    solved, calls_off = _spied_wave(monkeypatch, n, forecast=False)
    assert all(c["accepted"] for c in calls), [(c["n"], c["accepted"]) for c in calls]
    assert not all(c["accepted"] for c in calls_off)
    assert len(calls) < len(calls_off)
    h0 = 0.4e-6 * np.cos(2 * math.pi * (np.arange(n) + 0.5) / n)
    crest = float((h0 - foretold).max())
    assert crest > 0.05e-6
    assert np.abs(foretold - solved).max() < 0.02 * crest


def test_the_relaxed_update_wears_a_cosine_by_the_cell_size():
    """The previous default, for contrast: its relief is one cell's, so the worn depth halves
    with the cell while the implicit one does not move (the test above)."""
    depth = {}
    for n in (64, 128):
        prof, _, _ = _worn_wave(n, "relaxed")
        h0 = 0.4e-6 * np.cos(2 * math.pi * (np.arange(n) + 0.5) / n)
        depth[n] = float((h0 - prof).max())
    assert depth[128] < 0.75 * depth[64]


@pytest.mark.slow
def test_a_gear_flank_worn_without_pits_ends_no_steeper(tmp_path):
    """The paper gear at the pitch-side single-pair point (position 3, S = −0.39), k_lub =
    5e-11 s, no fatigue: two blocks of implicit wear lower both flanks' RMS slope."""
    from pathlib import Path

    from micropit_hpc.scene import load_scene
    root = Path(__file__).resolve().parents[1]
    scene = load_scene(root / "scenes" / "paper_gear_z23.toml")
    scene = dataclasses.replace(
        # 10 steps, the kinematic rule held off (the wear's polish, not the sampling, is tested)
        scene, window=dataclasses.replace(scene.window, nx=32, ny=None, steps=10,
                                          steps_per_peak_spacing=0.25),
        fatigue=dataclasses.replace(scene.fatigue, B=1e11),
        life=dataclasses.replace(scene.life, integration="adaptive", block=0.5e6,
                                 wear_integration="implicit"))
    cyc = PositionCycle(contact_study(scene), 3, k_lub=5e-11)
    state = initial_state(cyc)
    dx = cyc.grid.dx
    before = [rms_slope(b.heights, dx) for b in state.bodies]
    for _ in range(2):
        rec = run_block(cyc, state, scene.life)
        assert rec.Ap == (0.0, 0.0)
        assert all(s <= b for s, b in zip(rec.slope, before, strict=True)), (rec.slope, before)
    assert min(rec.wear_mean) > 0.3e-6


@pytest.mark.slow
def test_a_block_after_a_restart_repeats_the_straight_run():
    """The implicit wear keeps no state across blocks beyond the life state (its step
    controller and warm starts begin afresh at each block): block 2 on a fresh cycle from a
    copy of the state after block 1 repeats the straight run bit for bit."""
    import copy

    from helpers import tiny_doc
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    doc["life"]["wear_integration"] = "implicit"
    scene = scene_from_dict(doc, "tiny.toml")
    study = contact_study(scene)
    straight = PositionCycle(study, 1, k_lub=1e-11)
    a = initial_state(straight)
    first = run_block(straight, a, scene.life)
    assert first.wear_cycles > 0 and min(first.wear_mean) > 0
    # summary.csv carries the block's numerics (docs/outputs.md)
    from micropit_hpc.plan import WorkItem
    from micropit_hpc.study import SUMMARY_COLUMNS, summary_rows
    rows = [dict(zip(SUMMARY_COLUMNS, r, strict=True)) for r in summary_rows(
        WorkItem(0, 1, 1e-11, 1.0, 0), study.conditions[0], [first], 1.0)]
    for r in rows:
        assert (r["wear_cycles"], r["sub_blocks"]) == (first.wear_cycles, first.sub_blocks)
        assert r["phi"] == first.phi and r["pit_load_pct"] == 100 * first.pit_load
    b = copy.deepcopy(a)
    run_block(straight, a, scene.life)
    run_block(PositionCycle(study, 1, k_lub=1e-11), b, scene.life)
    for x, y in zip(a.bodies, b.bodies, strict=True):
        assert np.array_equal(x.heights, y.heights) and np.array_equal(x.damage, y.damage)
        assert np.array_equal(x.pitted, y.pitted)


def test_a_contact_that_fails_on_an_iterate_ends_the_solve_with_the_best_one():
    """An extrapolated iterate whose contact does not converge (ContactError) ends the solve
    unconverged, with the best iterate evaluated before it, so the caller can shorten the
    step; other errors pass through."""
    rng = np.random.default_rng(5)
    B = rng.normal(size=(4, 4))
    a, J = np.array([2e-12, 1e-12, 1e-12, 3e-12]), 40.0 * (B @ B.T + np.eye(4))
    good = _linear(a, J)
    calls = []

    def flaky(w):
        calls.append(1)
        if len(calls) == 3:                     # the solve's third contact
            raise ContactError("did not converge")
        return good(w)
    start = good((np.zeros(2), np.zeros(2)))
    sol = backward_euler(flaky, start, 1.0, 1e-22, errors=(ContactError,))
    assert not sol.converged and len(calls) == 3 and sol.iterations == len(calls)
    assert sol.history[-1] == math.inf and sol.residual == min(sol.history)
    with pytest.raises(ContactError):
        calls.clear()
        backward_euler(flaky, start, 1.0, 1e-22)
