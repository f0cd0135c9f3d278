"""The mixed-lubrication model: rheology, the [V00] calibration case, the dispersion relation,
and the limits (thick film: no solid contact; vanishing film: the dry solution)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import E_PRIME, SOLVER, mixed_model, mixed_settings, random_pair

from micropit_hpc.compiled import compiled_module
from micropit_hpc.hertz import elliptical_contact
from micropit_hpc.lubrication import rheology
from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.lubrication.mixed import (
    MixedLubrication,
    restore_mean,
    solve_dispersion,
    solve_dispersion_rows,
)
from micropit_hpc.spectral import Grid, rfft_plan


def test_rheology_values():
    """Bulk modulus ≈ 17 GPa at 1.1 GPa (MODEL App. A.3); c_ρ from 1 at p = 0 to 1.34 as
    p → ∞; Eyring viscosities → η at zero shear and η_x ≪ η_y ≪ η at high shear, with
    V = η_x/η_y ≈ τ0/τ_m (App. A.3 gear position 3: τ_m ≈ 174 MPa, V ≈ 0.05)."""
    assert rheology.bulk_modulus(1.1e9) / 1e9 == pytest.approx(17.0, abs=0.5)
    assert rheology.density_correction(0.0) == 1.0
    assert rheology.density_correction(1e15) == pytest.approx(1.34, rel=1e-4)
    ex, ey = rheology.eyring_viscosities(5.0, 9e6, 0.0)
    assert ex == ey == 5.0
    eta = rheology.barus_viscosity(0.09, 21e-9, 1.10e9)
    tau_m = 174e6
    gamma = 9e6 * math.sinh(tau_m / 9e6) / eta    # the shear rate that gives τ_m = 174 MPa
    ex, ey = rheology.eyring_viscosities(eta, 9e6, gamma)
    assert ex / ey == pytest.approx(9e6 / tau_m / math.tanh(tau_m / 9e6), rel=1e-9)
    assert ex / ey == pytest.approx(0.05, abs=0.005)


def _v00_contact():
    """Physical inputs with the [V00] numbers M = 1007.6, L = 12.05 (circular contact)."""
    R, eta0, u = 0.01, 0.05, 1.0
    U = eta0 * u / (E_PRIME * R)
    alpha = 12.05 / (E_PRIME * (2 * U) ** 0.25)
    F = 1007.6 * E_PRIME * R**2 * (2 * U) ** 0.75
    a = elliptical_contact(R, R, E_PRIME / 2, load=F).ax
    return R, eta0, u, alpha, F, a


def test_v00_pure_rolling_calibration():
    """[choice] docs/model.md §4.1 step 2: with the calibrated prefactor the model reproduces
    A_d/A_i = 0.739 of [V00] (M = 1007.6, L = 12.05, λ/a = 0.25, pure rolling), computed from
    physical inputs through Moes' M, L, the Hertz radius and the mode's wavelength; the
    printed prefactor 0.8 would give 0.831."""
    R, eta0, u, alpha, F, a = _v00_contact()
    lam = 0.25 * a
    g = Grid(64, 8, 8 * lam, 8 * lam)            # mode 8 along x has wavelength λ
    model = MixedLubrication(g, geometry="elliptical", load=F, R=R, b=a, u1=u, u2=u,
                             h_mean=1e-6, E_prime=E_PRIME, **mixed_settings(eta0, alpha))
    assert model.moes == pytest.approx((1007.6, 12.05), rel=1e-12)
    _, h_t, _ = model.lubricated_factors(1, 0.5e9, 1e-5)
    assert h_t[8, 0] == pytest.approx(0.739, abs=5e-4)
    printed = MixedLubrication(g, geometry="elliptical", load=F, R=R, b=a, u1=u, u2=u,
                               h_mean=1e-6, E_prime=E_PRIME,
                               **mixed_settings(eta0, alpha, prefactor=0.8))
    assert printed.lubricated_factors(1, 0.5e9, 1e-5)[1][8, 0] == pytest.approx(0.831, abs=1e-3)


def test_pure_rolling_clearance_is_the_reduced_roughness():
    """End to end at pure rolling and a thick film, where the window enters the contact: the
    output clearance is h̄ + 0.739 × the sinusoidal roughness, and the pressure is the one that
    deforms it so (0.261 of the flattening pressure E'κ/4 · amplitude)."""
    R, eta0, u, alpha, F, a = _v00_contact()
    lam = 0.25 * a
    g = Grid(64, 8, 8 * lam, 8 * lam)
    amp = 1e-8
    z1 = np.broadcast_to((amp * np.cos(2 * np.pi * g.x / lam))[:, None], g.shape).copy()
    fft = rfft_plan(g.shape)
    r1, r2 = fft.forward(-z1), np.zeros(g.spectral_shape, complex)
    model = MixedLubrication(g, geometry="elliptical", load=F, R=R, b=a, u1=u, u2=u,
                             h_mean=1e-6, E_prime=E_PRIME,
                             **mixed_settings(eta0, alpha))
    sol = model.solve((r1, r2), (r1, r2), 0.5e9, 1e-9)
    assert sol.phi == 0.0
    expected = 1e-6 - 0.739 * z1
    assert np.abs(sol.clearance - expected).max() < 5e-4 * amp
    kappa = 2 * np.pi / lam
    p_amp = (1 - 0.739) * E_PRIME * kappa / 4 * amp
    assert np.abs(sol.pressure - 0.5e9 - p_amp * z1 / amp).max() < 5e-3 * p_amp


def test_complementary_wave_decays_from_the_inlet():
    """|D| ≤ 1, falling with time; a more viscous film keeps the wave longer (pure rolling)."""
    R, eta0, u, alpha, F, a = _v00_contact()
    g = Grid(64, 8, a, a)
    decay = []
    for eta in (eta0, 100 * eta0):
        model = MixedLubrication(g, geometry="elliptical", load=F, R=R, b=a, u1=u, u2=u,
                                 h_mean=1e-6, E_prime=E_PRIME,
                                 **mixed_settings(eta, alpha))
        d = [np.abs(model.lubricated_factors(1, 0.5e9, t)[2][1:, 0]) for t in (1e-6, 1e-5, 1e-4)]
        assert np.all(d[0] <= 1.0) and np.all(d[1] <= d[0]) and np.all(d[2] <= d[1])
        assert d[2].min() < 0.9 * d[0].min()
        decay.append(d[2])
    assert np.all(decay[1] >= decay[0])


needs_numba = pytest.mark.skipif(compiled_module("lubrication._mixed_numba") is None,
                                 reason="Numba not installed")
KERNELS = ["numpy", pytest.param("numba", marks=needs_numba)]


@pytest.mark.parametrize("kernel", KERNELS)
def test_dispersion_relation_residual_and_branch(kernel):
    """Newton with continuation solves the relation to round-off for gear-like numbers where
    the viscous term dominates, on the decaying branch (Im ψ ≥ 0)."""
    g = Grid(64, 32, 3.7e-4, 3.7e-4)
    kx, ky = g.kx + 0 * g.ky, g.ky + 0 * g.kx
    ub, ui, h, Ep, B = 2.0, 2.4, 0.7e-6, E_PRIME * 1.0, 17e9
    for eta_x, eta_y in ((7.5, 130.0), (1e8, 1e8), (1e-3, 1e-3)):
        psi, res = solve_dispersion(kx * ui / ub, Ep * h**3 / (48 * ub), h * Ep / (4 * B), ky,
                                    eta_x, eta_y, kernel=kernel)
        assert res < 1e-10
        assert psi.imag.min() >= -1e-9 * np.abs(psi).max()


@needs_numba
def test_compiled_dispersion_equals_the_reference_to_round_off():
    """The compiled relation (a mode leaves a stage once its Newton step is below 1e-10 of
    |ψ|) gives the reference's ψ (every mode through all 8 × 8 steps) to round-off: the
    difference of two converged Newton solves is a few ulps of the residual's scale
    max(|ψ|, |a|) per mode; 64 ulps allow for the conditioning of the relation. Gear-like
    numbers at 256² (viscous, sliding either way), and the inviscid and the very viscous
    ends."""
    g = Grid(256, 256, 2.05e-4, 2.05e-4)
    kx, ky = g.kx + 0 * g.ky, g.ky + 0 * g.kx
    ub, h, Ep, B = 7.6, 0.37e-6, E_PRIME * 1.0, 17e9
    for ui, eta_x, eta_y in ((9.8, 7.5, 130.0), (5.4, 30.0, 300.0), (9.8, 1e8, 1e8),
                             (5.4, 1e-3, 1e-3)):
        args = (kx * ui / ub, Ep * h**3 / (48 * ub), h * Ep / (4 * B), ky, eta_x, eta_y)
        ref, res_ref = solve_dispersion(*args, kernel="numpy")
        new, res_new = solve_dispersion(*args, kernel="numba")
        scale = np.maximum(np.abs(ref), np.abs(args[0]))
        assert np.all(np.abs(new - ref) <= 64 * np.finfo(float).eps * scale)
        assert res_new < 1e-10 and res_ref < 1e-10


@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("shape", [(64, 32), (65, 33), (2, 8)])
def test_dispersion_on_the_positive_rows_mirrored_equals_the_whole_spectrum(shape, kernel):
    """ψ(−a, k_y) = −conj ψ(a, k_y): the half spectrum solved on its rows k_x ≥ 0 and
    mirrored is the whole spectrum's solution bit for bit (even and odd nx; 2 rows: no pair,
    the whole spectrum), for sliding either way and viscous to inviscid numbers."""
    g = Grid(shape[0], shape[1], 3.7e-4, 3.7e-4)
    kx, ky = g.kx + 0 * g.ky, g.ky + 0 * g.kx
    ub, h, Ep, B = 2.0, 0.7e-6, E_PRIME * 1.0, 17e9
    for ui, eta_x, eta_y in ((2.4, 7.5, 130.0), (1.6, 30.0, 300.0), (2.4, 1e8, 1e8),
                             (1.6, 1e-3, 1e-3)):
        args = (kx * ui / ub, Ep * h**3 / (48 * ub), h * Ep / (4 * B), ky, eta_x, eta_y)
        whole, res = solve_dispersion(*args, kernel=kernel)
        rows, res_rows = solve_dispersion_rows(*args, kernel=kernel)
        assert np.array_equal(rows.view(np.uint64), whole.view(np.uint64))
        assert res_rows == res


def test_thick_film_has_no_solid_contact():
    g, (z1, z2) = random_pair()
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    sol = mixed_model(g, h_mean=3e-6).solve(r, r, 1.0e9, 5e-5)      # Λ = 7
    assert sol.phi == 0.0 and sol.clearance.min() > 0.0
    assert sol.clearance.mean() == pytest.approx(3e-6, rel=1e-12)
    assert sol.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)


def test_vanishing_film_gives_the_dry_solution():
    """h̄ → 0: the solids carry everything (φ = 1) and pressure and clearance are those of
    the dry contact of the same roughness."""
    g, (z1, z2) = random_pair()
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    sol = mixed_model(g, h_mean=1e-12).solve(r, r, 1.0e9, 5e-5)
    dry = solve_dry_contact(-(z1 + z2), ElasticHalfSpaces(g, E_PRIME), 1.0e9, p_lim=4.2e9,
                            **SOLVER)
    assert sol.phi == 1.0
    assert np.abs(sol.pressure - dry.pressure).max() < 1e-6 * dry.pressure.max()
    assert np.abs(sol.clearance - dry.gap).max() < 1e-6 * z1.std()


def test_intermediate_film_balances_the_flow():
    g, (z1, z2) = random_pair()
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    h = 0.35e-6
    sol = mixed_model(g, h_mean=h).solve(r, r, 1.0e9, 5e-5)
    assert 0.0 < sol.phi < 1.0
    c_rho = rheology.density_correction(sol.phi * 1.0e9)
    assert sol.film_mean == pytest.approx(c_rho * h, rel=2e-4)
    assert sol.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    assert 0.0 <= sol.pressure.min() and sol.pressure.max() <= 4.2e9
    thinner = mixed_model(g, h_mean=0.5 * h).solve(r, r, 1.0e9, 5e-5)
    assert thinner.phi > sol.phi                 # less film, more load on the asperities


@pytest.mark.parametrize("kernel", KERNELS)
def test_restore_mean_is_exact_with_clipping(kernel):
    rng = np.random.default_rng(0)
    p = rng.normal(1e9, 2e9, (32, 32))
    q = restore_mean(p, 1.2e9, 4e9, kernel=kernel)
    assert q.mean() == pytest.approx(1.2e9, rel=1e-12)
    assert q.min() >= 0.0 and q.max() <= 4e9


def _numpy_mean(p, c, p_lim):
    return np.clip(p + c, 0.0, p_lim).mean()


def _compiled_mean(p, c, p_lim):
    mod = compiled_module("lubrication._mixed_numba")
    return mod.clipped_sum(p.ravel(order="K"), c, p_lim)[0] / p.size


def _restore_mean_by_bisection(p, p_mean, p_lim=math.inf, mean=_numpy_mean):
    """The definition restore_mean keeps: bisection of the whole bracket down to adjacent
    floats, np.clip and the kernel's mean at every step (the code before the narrow start)."""
    lo, hi = p_mean - p.max(), 2 * p_mean - p.min()
    for _ in range(200):
        c = 0.5 * (lo + hi)
        if not lo < c < hi:
            break
        if mean(p, c, p_lim) > p_mean:
            hi = c
        else:
            lo = c
    q_lo, q_hi = np.clip(p + lo, 0.0, p_lim), np.clip(p + hi, 0.0, p_lim)
    near_lo = abs(mean(p, lo, p_lim) - p_mean) <= abs(mean(p, hi, p_lim) - p_mean)
    return q_lo if near_lo else q_hi


def _restore_cases():
    rng = np.random.default_rng(7)
    yield rng.normal(1e9, 2e9, (32, 32)), 1.2e9, 4e9            # clipped at both ends
    yield rng.normal(1e9, 2e9, (64, 64)), 0.3e9, 4e9
    yield rng.uniform(0.5e9, 1.5e9, (16, 24)), 1e9, 4e9           # no clipping: c ≈ p̄ − ⟨p⟩
    yield rng.uniform(0.5e9, 1.5e9, (16, 24)), 1e9, math.inf
    yield np.full((8, 8), 2e9), 1e9, 4e9                          # constant
    yield np.zeros((8, 8)), 1e9, 4e9                              # all at zero
    yield np.where(rng.random((64, 64)) < 0.05, 3.9e9, 0.0), 0.2e9, 4e9   # few spots
    yield np.where(rng.random(3000) < 0.5, 4e9, 1e3), 3.99e9, 4e9          # 1-D, near p_lim
    yield np.asfortranarray(rng.normal(0.0, 1e9, (48, 40))), 0.7e9, 3e9    # F order
    yield rng.normal(0.0, 1e9, (64, 80))[::2, 1::3], 0.4e9, 4e9   # a strided view
    yield rng.lognormal(20.0, 1.0, (30, 50)), 1e-3, 4e9            # tiny mean
    a = rng.normal(1e9, 1e9, (64, 64))
    a[a < 0] = 0.0
    yield a, float(a.mean()), 4e9                                 # already at p̄


@pytest.mark.parametrize("kernel", KERNELS)
def test_restore_mean_is_the_bisection_bit_for_bit(kernel):
    """The narrow start (Newton, then a widened bracket) ends the bisection on the same two
    floats as the full bracket, so the field is the same array bit for bit: with NumPy's mean
    as with the compiled one (each against a bisection on its own mean)."""
    mean = _numpy_mean if kernel == "numpy" else _compiled_mean
    for p, p_mean, p_lim in _restore_cases():
        q = restore_mean(p, p_mean, p_lim, kernel=kernel)
        ref = _restore_mean_by_bisection(p, p_mean, p_lim, mean)
        assert q.shape == ref.shape and q.flags.f_contiguous == ref.flags.f_contiguous
        assert np.array_equal(q.view(np.int64), ref.view(np.int64)), (p.shape, p_mean)


@needs_numba
def test_restore_mean_kernels_agree_to_their_rounding():
    """The two kernels add the clipped field in different orders, so their constants c may
    differ, but each field's exact mean (math.fsum) is p̄ to the rounding of an n-term sum
    (n ε max q), and the fields differ by at most twice that over the share s of points
    strictly inside (0, p_lim), where the mean moves with c at slope s."""
    eps = np.finfo(float).eps
    for p, p_mean, p_lim in _restore_cases():
        a = restore_mean(p, p_mean, p_lim, kernel="numpy")
        b = restore_mean(p, p_mean, p_lim, kernel="numba")
        n, top = p.size, max(float(a.max()), float(b.max()), p_mean)
        bound = n * eps * top
        for q in (a, b):
            assert abs(math.fsum(q.ravel()) / n - p_mean) <= bound, (p.shape, p_mean)
        s = np.count_nonzero((a > 0.0) & (a < p_lim)) / n
        if s > 0:
            assert np.max(np.abs(a - b)) <= 2 * bound / s + 2 * eps * top, (p.shape, p_mean)


def test_cached_lubricated_factors_equal_the_computed_ones():
    """The per-step factor cache returns exactly what lubricated_factors computes."""
    g, _ = random_pair()
    model = mixed_model(g, h_mean=0.35e-6)
    h_a, h_t, D = model.lubricated_factors(2, 1.0e9, 5e-5)
    for _ in range(2):                   # the miss, then the hit
        c_a, c_dh, c_D = model.cached_factors(2, 1.0e9, 5e-5)
        assert np.array_equal(c_a, h_a) and np.array_equal(c_D, D)
        assert np.array_equal(c_dh, h_t - h_a)
    assert len(model._factors) == 1
    assert not np.array_equal(model.cached_factors(1, 1.0e9, 5e-5)[0], h_a)   # S ≠ 0


def test_warm_start_from_the_last_evaluation_gives_the_same_solution_in_fewer_iterations():
    """A step solved again with the last evaluation's warm starts (root, trial fractions)
    converges in a few iterations to the same pressure and load fraction."""
    g, (z1, z2) = random_pair()
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))
    model = mixed_model(g, h_mean=0.35e-6)
    warm = {}
    cold = model.solve(r, r, 1.0e9, 5e-5, warm=warm)
    assert 0.0 < cold.phi < 1.0 and set(warm) >= {0.25, "root", "phi"}
    again = model.solve(r, r, 1.0e9, 5e-5, warm=warm)
    assert again.iterations < 0.2 * cold.iterations
    assert again.phi == pytest.approx(cold.phi, abs=1e-3)
    assert np.abs(again.pressure - cold.pressure).max() < 1e-3 * cold.pressure.max()
    assert again.pressure.mean() == pytest.approx(1.0e9, rel=1e-12)
    # a slightly changed surface (a sub-block's wear) still converges to its own solution
    worn = (fft.forward(-0.98 * z1), r[1])
    fresh = model.solve(worn, r, 1.0e9, 5e-5)
    warmed = model.solve(worn, r, 1.0e9, 5e-5, warm=warm)
    assert warmed.iterations < fresh.iterations
    assert warmed.phi == pytest.approx(fresh.phi, abs=1e-3)
    assert np.abs(warmed.pressure - fresh.pressure).max() < 1e-2 * fresh.pressure.max()
