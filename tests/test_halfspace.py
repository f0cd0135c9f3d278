"""Micro stress field of the half-space (docs/model.md §4.2, Appendix A.1): boundary values,
equilibrium, the A.1 trace relation, the printed A.1 formulas mode by mode (incl. Nyquist modes),
the Boussinesq point-load limit and the Hertz line contact of Appendix A.2."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import j1

from micropit_hpc.mechanics import VOIGT, HalfSpaceStress, depth_layers
from micropit_hpc.mechanics.hertz_field import line_contact_stress
from micropit_hpc.spectral import Grid

NU = 0.3
XX, YY, ZZ, YZ, XZ, XY = range(6)
assert VOIGT == ("xx", "yy", "zz", "yz", "xz", "xy")


def random_tractions(shape, seed):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((3, *shape)) * np.array([1.0, 0.4, 0.3])[:, None, None] + 2.0


# --- depth layers ---------------------------------------------------------------------------

def test_depth_layers():
    z = depth_layers(15, 0.25e-3)
    assert z.shape == (15,) and z[0] == 0.0 and z[-1] == pytest.approx(0.25e-3, rel=1e-15)
    np.testing.assert_allclose(z, 0.25e-3 * (np.arange(15) / 14) ** 2, rtol=1e-15)
    np.testing.assert_allclose(depth_layers(5, 2.0, "uniform"), [0, 0.5, 1, 1.5, 2])
    assert depth_layers(1, 1.0).tolist() == [0.0]
    with pytest.raises(ValueError):
        depth_layers(0, 1.0)
    with pytest.raises(ValueError):
        depth_layers(4, 1.0, "log")


# --- boundary values, zero mean, API ---------------------------------------------------------

@pytest.mark.parametrize("shape", [(32, 24), (27, 15)])
def test_surface_values_are_the_fluctuating_tractions(shape):
    """σ_zz(0) = −(p − p̄), σ_xz(0) = −(q_x − q̄_x), σ_yz(0) = −(q_y − q̄_y) to round-off; the
    even grid has Nyquist content in every traction."""
    g = Grid(*shape, 1e-4, 0.7e-4)
    p, qx, qy = random_tractions(shape, 1)
    s = HalfSpaceStress(g, [0.0, 1e-6], NU).from_tractions(p, qx, qy)
    for c, f in ((ZZ, p), (XZ, qx), (YZ, qy)):
        np.testing.assert_allclose(s[c, 0], -(f - f.mean()), rtol=0, atol=1e-13)
    # every layer of every component has zero mean (the mean mode belongs to the macro field)
    assert np.abs(s.mean(axis=(2, 3))).max() < 1e-14


def test_api_options_agree():
    g = Grid(16, 12, 1.0, 1.0)
    p, qx, _ = random_tractions(g.shape, 2)
    hs = HalfSpaceStress(g, depth_layers(5, 0.2), NU)
    full = hs.from_tractions(p, qx)
    assert full.shape == hs.shape == (6, 5, 16, 12) and full.dtype == np.float64
    np.testing.assert_array_equal(full, hs.from_tractions(p, qx, np.zeros_like(p)))
    P, Tx, _ = hs.spectra(p, qx)
    out = np.empty(hs.shape)
    assert hs.stresses(P, Tx, out=out) is out
    np.testing.assert_array_equal(out, full)
    np.testing.assert_array_equal(hs.stresses(P, Tx, layers=[1, 3]), full[:, [1, 3]])
    with pytest.raises(ValueError):
        hs.stresses(P[:, :-1], Tx)
    with pytest.raises(ValueError):
        hs.stresses(P, Tx, out=np.empty((6, 4, 16, 12)))
    with pytest.raises(ValueError):
        HalfSpaceStress(g, [-1e-3], NU)
    # the layers one at a time, as views of the plan's output: the very numbers, both kernels
    for kernel in ("numpy", None):
        ref = hs.stresses(P, Tx, kernel=kernel)
        got = [(kk, sigma.copy()) for kk, sigma in hs.layer_fields(P, Tx, kernel=kernel,
                                                                  layers=slice(1, 4))]
        assert [kk for kk, _ in got] == [0, 1, 2]
        for kk, sigma in got:
            np.testing.assert_array_equal(sigma, ref[:, 1 + kk])
    with pytest.raises(ValueError, match="P_hat has shape"):
        next(hs.layer_fields(P[:, :-1], Tx))


# --- the printed A.1 formulas, mode by mode -------------------------------------------------

def a1_printed(al, be, z, nu, P, Tx, Ty):
    """docs/model.md Appendix A.1 exactly as printed (independent of the library's regrouping)."""
    ze = np.hypot(al, be)
    zs = np.where(ze > 0, ze, 1.0)
    E = np.where(ze > 0, np.exp(-ze * z), 0.0)   # mean mode excluded
    i = 1j
    a, b = al / zs, be / zs
    xx = E * (P * (a**2 * (1 - zs * z) + 2 * nu * b**2)
              - i * Tx * a * (2 + 2 * nu * b**2 - al**2 * z / zs)
              - i * Ty * b * (2 * nu * b**2 - al**2 * z / zs))
    yy = E * (P * (b**2 * (1 - zs * z) + 2 * nu * a**2)
              - i * Tx * a * (2 * nu * a**2 - be**2 * z / zs)
              - i * Ty * b * (2 + 2 * nu * a**2 - be**2 * z / zs))
    zz = E * (P * (1 + zs * z) - i * Tx * al * z - i * Ty * be * z)
    xy = E * (P * a * b * ((1 - 2 * nu) - zs * z)
              - i * Tx * b * (1 - 2 * nu * a**2 - al**2 * z / zs)
              - i * Ty * a * (1 - 2 * nu * b**2 - be**2 * z / zs))
    yz = E * (-i * P * be * z - Tx * al * be / zs * z + Ty * (1 - be**2 * z / zs))
    xz = E * (-i * P * al * z + Tx * (1 - al**2 * z / zs) - Ty * al * be / zs * z)
    return np.array([xx, yy, zz, yz, xz, xy])


def _modes(n, d):
    """Angular wavenumbers of an axis, its indices and weights, the Nyquist mode of an even
    axis split into ±k_N with weight ½ each (the symmetric band-limited interpolant)."""
    k = 2 * np.pi * np.fft.fftfreq(n, d)
    idx = np.arange(n)
    w = np.ones(n)
    if n % 2 == 0:
        k = np.append(k, -k[n // 2])
        idx = np.append(idx, n // 2)
        w[n // 2] = 0.5
        w = np.append(w, 0.5)
    return k, idx, w


@pytest.mark.parametrize("shape", [(12, 10), (9, 7), (10, 1)])
def test_kernels_match_printed_A1_by_direct_mode_summation(shape):
    """Sum Σ_modes K(α, β, z) F(α, β) e^{i(αx+βy)} over the full spectrum with the printed A.1
    kernels (Nyquist modes split into ±k_N), by dense matrices, and compare at the nodes.
    The result must come out real: a wrong Nyquist treatment leaves an imaginary part and a
    different real part (the even grid's tractions have Nyquist content)."""
    nx, ny = shape
    g = Grid(nx, ny, 3.0, 2.0)
    p, qx, qy = random_tractions(shape, 3)
    z = np.array([0.0, 0.03, 0.2, 0.7])
    lib = HalfSpaceStress(g, z, NU).from_tractions(p, qx, qy)
    Fs = [np.fft.fft2(-f) for f in (p, qx, qy)]
    kx, ix, wx = _modes(nx, g.dx)
    ky, iy, wy = _modes(ny, g.dy)
    al, be = kx[:, None], ky[None, :]
    W = wx[:, None] * wy[None, :]
    P, Tx, Ty = (F[np.ix_(ix, iy)] * W for F in Fs)
    ex = np.exp(1j * kx[:, None] * (np.arange(nx) * g.dx)[None, :])   # (modes, nodes)
    ey = np.exp(1j * ky[:, None] * (np.arange(ny) * g.dy)[None, :])
    for k, zk in enumerate(z):
        K = a1_printed(al, be, zk, NU, P, Tx, Ty)
        ref = np.einsum("im,cij,jn->cmn", ex, K, ey) / (nx * ny)
        scale = np.abs(ref.real).max()
        assert np.abs(ref.imag).max() < 1e-12 * scale
        np.testing.assert_allclose(lib[:, k], ref.real, rtol=0, atol=1e-12 * scale)


def test_nyquist_only_traction():
    """A traction with content only on the Nyquist row and column: p = (−1)^i cos(2πy/L_y) +
    (−1)^j cos(2πx/L_x), q_x = (−1)^i sin(2πy/L_y). At the nodes sin(πx/Δ) = 0, so the exact
    stresses of the band-limited traction keep only the kernel parts even in the Nyquist
    wavenumber; e.g. σ_zz = −(1 + ζz)e^{−ζz} p-term (the q_x term of σ_zz is odd in α: zero)."""
    nx, ny = 16, 8
    g = Grid(nx, ny, 1.6, 0.8)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    by, bx = 2 * np.pi / g.ly, 2 * np.pi / g.lx
    cy, sy = np.cos(by * j * g.dy), np.sin(by * j * g.dy)
    p1, p2 = (-1.0) ** i * cy, (-1.0) ** j * np.cos(bx * i * g.dx)
    qx = (-1.0) ** i * sy
    z = np.array([0.0, 0.05, 0.2])
    s = HalfSpaceStress(g, z, NU).from_tractions(p1 + p2, qx)
    z1 = math.hypot(np.pi / g.dx, by)
    z2 = math.hypot(bx, np.pi / g.dy)
    for k, zk in enumerate(z):
        expect = -((1 + z1 * zk) * math.exp(-z1 * zk) * p1
                   + (1 + z2 * zk) * math.exp(-z2 * zk) * p2)
        np.testing.assert_allclose(s[ZZ, k], expect, rtol=0, atol=1e-13)


# --- equilibrium and the trace relation -----------------------------------------------------

def _spectral_derivatives(f, g):
    """∂f/∂x, ∂f/∂y of a field without Nyquist content (odd grid sizes)."""
    F = np.fft.rfft2(f)
    return (np.fft.irfft2(1j * g.kx * F, s=g.shape), np.fft.irfft2(1j * g.ky * F, s=g.shape))


def test_equilibrium_to_round_off():
    """∂σ_ij/∂x_j = 0 for random tractions at several depths. x, y derivatives spectrally (odd
    grid: no Nyquist mode, whose derivative the nodes cannot represent); ∂/∂z by the fourth-order
    central difference [8(f(z+h) − f(z−h)) − (f(z+2h) − f(z−2h))]/(12h) with h = 1e-3/ζ_max:
    truncation h⁴ζ_max⁵|σ|/30 ≈ 3e-14 ζ_max|σ|, round-off ≈ 1.5 ε|σ|/h ≈ 3e-13 ζ_max|σ|.
    Tolerance 1e-10 of the largest single term; a wrong sign in any kernel term gives O(1)."""
    g = Grid(45, 39, 1.0, 0.9)
    p, qx, qy = random_tractions(g.shape, 4)
    zmax = float(g.kappa.max())
    h = 1e-3 / zmax
    depths = np.array([0.3, 2.0, 10.0]) * g.dx
    z = (depths[:, None] + h * np.array([-2, -1, 0, 1, 2])[None, :]).ravel()
    s = HalfSpaceStress(g, z, NU).from_tractions(p, qx, qy).reshape(6, depths.size, 5, *g.shape)
    dz = (8 * (s[:, :, 3] - s[:, :, 1]) - (s[:, :, 4] - s[:, :, 0])) / (12 * h)
    mid = s[:, :, 2]
    rows = ((XX, XY, XZ), (XY, YY, YZ), (XZ, YZ, ZZ))
    for k in range(depths.size):
        for cx, cy, cz in rows:
            tx = _spectral_derivatives(mid[cx, k], g)[0]
            ty = _spectral_derivatives(mid[cy, k], g)[1]
            tz = dz[cz, k]
            scale = max(np.abs(tx).max(), np.abs(ty).max(), np.abs(tz).max())
            assert np.abs(tx + ty + tz).max() < 1e-10 * scale


def test_trace_relation():
    """tr σ̂ = 2(1+ν) e^{−ζz}[P̂ − i(αT̂x + βT̂y)/ζ] (docs/model.md A.1 check), mean mode excluded."""
    g = Grid(25, 21, 2.0, 1.5)
    p, qx, qy = random_tractions(g.shape, 5)
    z = np.array([0.0, 0.05, 0.4])
    s = HalfSpaceStress(g, z, NU).from_tractions(p, qx, qy)
    P, Tx, Ty = (np.fft.rfft2(-f) for f in (p, qx, qy))
    ze = g.kappa
    zs = np.where(ze > 0, ze, 1.0)
    for k, zk in enumerate(z):
        T = 2 * (1 + NU) * np.exp(-ze * zk) * (P - 1j * (g.kx * Tx + g.ky * Ty) / zs)
        T[0, 0] = 0.0
        trace = np.fft.irfft2(T, s=g.shape)
        np.testing.assert_allclose(s[XX, k] + s[YY, k] + s[ZZ, k], trace, rtol=0,
                                   atol=1e-13 * np.abs(trace).max())


# --- Boussinesq point-load limit ------------------------------------------------------------

#: Σ' |n|⁻³ over the square lattice Z² \ {0}
S3 = 9.033621683100950


def boussinesq(x, y, z, F, nu):
    """Point force F (compressive) on the half-space, Johnson (1985) eq. 3.20 in cylindrical
    components, rotated to x, y (Voigt order). (1 − z/ρ)/r² is written 1/(ρ(ρ + z))."""
    r2 = x * x + y * y
    r = np.sqrt(r2)
    rho = np.sqrt(r2 + z * z)
    A = 1.0 / (rho * (rho + z))
    c = F / (2 * np.pi)
    s_r = c * ((1 - 2 * nu) * A - 3 * z * r2 / rho**5)
    s_t = -c * (1 - 2 * nu) * (A - z / rho**3)
    s_z = -3 * c * z**3 / rho**5
    t_rz = -3 * c * r * z * z / rho**5
    on = r2 > 0
    cos2 = np.divide(x * x, r2, out=np.full_like(r2, 0.5), where=on)
    sin2 = np.divide(y * y, r2, out=np.full_like(r2, 0.5), where=on)
    sc = np.divide(x * y, r2, out=np.zeros_like(r2), where=on)
    cos = np.divide(x, r, out=np.zeros_like(r), where=on)
    sin = np.divide(y, r, out=np.zeros_like(r), where=on)
    return np.array([s_r * cos2 + s_t * sin2, s_r * sin2 + s_t * cos2, s_z, t_rz * sin,
                     t_rz * cos, (s_r - s_t) * sc])


def test_boussinesq_point_load_limit():
    """A smooth localised load p = 2G_s − G_{√2 s} (G_s: unit Gaussian of width s = Δ; total force
    F = 1, second moment zero, so the leading finite-width correction (s²/2)∇²σ vanishes) at
    depths z = 20–30 s against the point-load field. The periodic FFT field equals the isolated
    field plus the images minus the mean-mode field U, so we add U (σ_zz = −p̄,
    σ_xx = σ_yy = −(1+2ν)p̄/2: the plane integral of eq. 3.20, p̄ = F/L²) and remove the images'
    leading term Δσ_xx = Δσ_yy = −(1+ν)F S₃ z/(2πL³) (∂_z(σ_r+σ_θ) = −(F/π)(1+ν)/r³ at the surface,
    summed over the square lattice). Remaining: the fourth-moment term ≈ 70 (s/z)⁴ ≤ 4.4e-4 of
    the scale 3F/(2πz²) (= |σ_zz| on the axis) and O((z/L)³) image terms (≈ 1e-4 here).
    Tolerance 1e-3 of the scale; without the mean-mode field the error is O(1)."""
    n = 256
    g = Grid(n, n, float(n), float(n))
    s = g.dx
    X, Y = np.meshgrid(g.x, g.y, indexing="ij")

    def gauss(w):
        return np.exp(-(X**2 + Y**2) / (2 * w * w)) / (2 * np.pi * w * w)

    p = 2 * gauss(s) - gauss(math.sqrt(2) * s)
    F = p.sum() * g.dx * g.dy
    assert F == pytest.approx(1.0, rel=1e-6)
    z = np.array([20.0, 25.0, 30.0]) * s
    st = HalfSpaceStress(g, z, NU).from_tractions(p, np.zeros_like(p))
    pbar = F / (g.lx * g.ly)
    st[ZZ] -= pbar
    st[XX] -= 0.5 * (1 + 2 * NU) * pbar
    st[YY] -= 0.5 * (1 + 2 * NU) * pbar
    for k, zk in enumerate(z):
        d = (1 + NU) * F * S3 * zk / (2 * np.pi * g.lx**3)
        field = st[:, k].copy()
        field[XX] += d
        field[YY] += d
        near = (np.abs(X) <= zk) & (np.abs(Y) <= zk)
        ref = boussinesq(X[near], Y[near], zk, F, NU)
        scale = 3 * F / (2 * np.pi * zk**2)
        err = np.abs(field[:, near] - ref).max() / scale
        assert err < 1e-3, (zk, err)


# --- Hertz line contact (docs/model.md A.2), the headline check ----------------------------------

def image_tail(x, z, M, L, w, Q, nu):
    """Σ over |n| > M of the images' far field (Flamant line loads w normal, Q tangential,
    Johnson 1985 §2.2–2.3), summed in ± pairs: σ_x ≈ −(2w/π) 2z/(nL)² + (2Q/π) 2x/(nL)²,
    τ_xz ≈ −(2Q/π) 2z/(nL)², σ_z = O(n⁻⁴); Σ_{n>M} n⁻² ≈ 1/(M + ½). Error O(M⁻³)."""
    c = 1.0 / (L * L * (M + 0.5))
    t = np.zeros((6, *np.broadcast(x, z).shape))
    t[XX] = -(2 * w / np.pi) * 2 * z * c + (2 * Q / np.pi) * 2 * x * c
    t[XZ] = -(2 * Q / np.pi) * 2 * z * c
    t[YY] = nu * t[XX]
    return t


def periodic_line_contact(x, z, b, p0, mu, nu, L, M=25):
    """The closed-form field of a row of Hertz contacts at x = nL: Σ_{|n|≤M} + far-field tail
    (checked against M = 6400: 1.5e-7 p0 at M = 25)."""
    ref = image_tail(x, z, M, L, math.pi * b * p0 / 2, mu * math.pi * b * p0 / 2, nu)
    for n in range(-M, M + 1):
        ref += line_contact_stress(x - n * L, z, b, p0, mu, nu)
    return ref


def line_load_spectrum(g, b, p0):
    """rfft2 half spectrum of p0√(1 − x²/b²) (uniform in y, centred on the grid's x = 0) from
    the exact Fourier transform πb p0 J1(kb)/(kb), not from samples."""
    K = np.abs(g.kx[:, 0] * b)
    Ks = np.where(K > 0, K, 1.0)
    ft = np.where(K > 0, np.pi * b * p0 * j1(Ks) / Ks, np.pi * b * p0 / 2)
    shift = (-1.0) ** np.arange(g.nx)          # x = 0 at index nx/2 (nx even)
    spec = np.zeros(g.spectral_shape, dtype=complex)
    spec[:, 0] = ft * shift / g.dx * g.ny
    return spec


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_hertz_line_contact_headline(mu):
    """FFT stresses of the Hertz line contact p = p0√(1−x²/b²), q = μp, against the closed form
    of A.2 within 1e-3 p0 at every grid point for 2Δ ≤ z ≤ 2b (Δ = b/256; the quadratic
    layers to 2b start at 0.0089b ≥ 2Δ).

    * Window L = 16b. The periodic FFT field + the mean-mode field U equals the exact sum over
      all images; U: σ_zz = −p̄, σ_xz = −q̄, σ_xx = −p̄ (the surface value −p averaged over the
      period), σ_yy = −2νp̄ (plane strain), uniform in z. The reference is that image sum
      (closed form for |n| ≤ 25 plus the Flamant tail; without the images the error would be
      0.04–0.08 p0 at z = 2b).
    * The load enters through its exact Fourier coefficients. Sampling p at the nodes instead
      misses force at the √-edges (trapezoid error ζ(−1/2)√(2/b) p0 Δ^{3/2} per edge, Navot
      1961), a line-load error felt as 1/r: see the next test. Above the Nyquist wavenumber the
      load is cut off; that error decays as e^{−πz/Δ} and is 2e-4 p0 at z = 1.6Δ but reaches
      0.06 p0 as z → 0 (Gibbs at the edges), so 2Δ is the shallowest depth a grid of spacing Δ
      resolves to this tolerance, whatever the kernels.
    Measured: 4e-6 p0 (μ = 0), 1e-5 p0 (μ = 0.3)."""
    b, p0 = 2e-4, 1.3e9
    L = 16 * b
    g = Grid(4096, 4, L, 1e-4)
    z = depth_layers(16, 2 * b)[1:]
    assert z[0] >= 2 * g.dx
    P = -line_load_spectrum(g, b, p0)
    s = HalfSpaceStress(g, z, NU).stresses(P, mu * P)
    assert np.abs(s[:, :, :, 1:] - s[:, :, :, :1]).max() < 1e-12 * p0   # uniform in y
    s = s[..., 0]
    pbar, qbar = math.pi * b * p0 / 2 / L, mu * math.pi * b * p0 / 2 / L
    s[ZZ] -= pbar
    s[XZ] -= qbar
    s[XX] -= pbar
    s[YY] -= 2 * NU * pbar
    ref = periodic_line_contact(g.x[None, :], z[:, None], b, p0, mu, NU, L)
    assert np.abs(s - ref).max() < 1e-3 * p0
    assert np.abs(s[[YZ, XY]]).max() < 1e-12 * p0


def test_sampled_hertz_pressure_error_is_the_edge_quadrature_error():
    """With the pressure sampled at the nodes (what the solver feeds), the field differs from
    the closed form by the trapezoid-rule defect of the √-edges: a line load
    δF = ζ(−1/2) √(2/b) p0 Δ^{3/2} (and μδF) at x = ±b (Navot's extension of Euler–Maclaurin;
    ζ(−1/2) = −0.2079), whose Flamant field decays as 1/r. At 32 points per b it is 2e-3 p0 at
    z = b/2. Subtracting it (with its periodic images) must leave < 5 % of it: the next terms
    are O(Δ/b) and O(Δ/r) relative (3 %, 6 % at r = b/2); measured 1 %."""
    b, p0, mu = 1.0, 1.0, 0.3
    L = 16 * b
    g = Grid(512, 2, L, 1.0)
    z = np.array([0.5, 1.0, 2.0]) * b
    x = g.x
    p = p0 * np.sqrt(np.clip(1 - (x / b) ** 2, 0.0, None))[:, None] * np.ones(g.ny)
    s = HalfSpaceStress(g, z, NU).from_tractions(p, mu * p)[..., 0]
    pbar = p.mean()
    s[ZZ] -= pbar
    s[XZ] -= mu * pbar
    s[XX] -= pbar
    s[YY] -= 2 * NU * pbar
    X, Z = x[None, :], z[:, None]
    err = s - periodic_line_contact(X, Z, b, p0, mu, NU, L)
    dF = -0.2078862250 * math.sqrt(2 / b) * p0 * g.dx**1.5
    defect = np.zeros_like(err)
    for x0 in (x1 + n * L for x1 in (-b, b) for n in range(-40, 41)):   # with its images
        xx = X - x0
        r4 = (xx * xx + Z * Z) ** 2
        P, Q = dF, mu * dF
        defect[XX] += -(2 * P / np.pi) * xx * xx * Z / r4 - (2 * Q / np.pi) * xx**3 / r4
        defect[ZZ] += -(2 * P / np.pi) * Z**3 / r4 - (2 * Q / np.pi) * xx * Z * Z / r4
        defect[XZ] += -(2 * P / np.pi) * xx * Z * Z / r4 - (2 * Q / np.pi) * xx * xx * Z / r4
    defect[YY] = NU * (defect[XX] + defect[ZZ])
    assert np.abs(err).max() > 1.5e-3 * p0           # the sampling error is real ...
    assert np.abs(err - defect).max() < 0.05 * np.abs(defect).max()   # ... and explained
