"""Macro stress fields of the smooth Hertz contact with Coulomb friction (docs/model.md §4.2).

* :func:`line_contact_stress`: closed form of the 2-D Hertz line contact with traction q = μp
  (McEwen 1949; Smith & Liu 1953; docs/model.md Appendix A.2), plane strain.
* :class:`EllipticalContactField` / :func:`elliptical_contact_stress`: the Hertz ellipse with
  traction μp in +x, computed once per contact by the Appendix A.1 kernels on a large, square,
  zero-padded periodic window fed with the *exact* Fourier transform of the Hertz pressure, plus
  the mean-mode field and the leading correction for the periodic images, then interpolated.

Layout: stresses are float64 arrays (6, ...) in Voigt order (xx, yy, zz, yz, xz, xy), tension
positive, z positive into the body; σ_zz(x, 0) = −p and σ_xz(x, 0) = −q for a traction q in +x
on the body (docs/model.md §1).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage, sparse
from scipy.special import spherical_jn

from micropit_hpc.mechanics.halfspace import HalfSpaceStress
from micropit_hpc.spectral import Grid, next_5smooth

__all__ = ["EllipticalContactField", "elliptical_contact_stress", "line_contact_stress"]


def _mn(x, z, b):
    """McEwen's m ≥ 0 and n (sign of x) with m² − n² = b² − x² + z², m n = x z (docs/model.md A.2).

    m² = ½[√((b²−x²+z²)² + 4x²z²) + (b²−x²+z²)], n² = ½[√(…) − (b²−x²+z²)], evaluated without
    cancellation: the larger of the two from the sum, the other from m n = |x| z. At z = 0:
    m = √(b²−x²), n = 0 inside the contact; m = 0, n = sign(x)√(x²−b²) outside."""
    A = b * b - x * x + z * z
    R = np.hypot(A, 2.0 * x * z)
    big = np.sqrt(0.5 * (R + np.abs(A)))          # m if A ≥ 0, |n| otherwise
    small = np.divide(np.abs(x) * z, big, out=np.zeros_like(big), where=big > 0)
    m = np.where(A >= 0, big, small)
    n = np.copysign(np.where(A >= 0, small, big), x)
    return m, n


def line_contact_stress(x, z, b, p0, mu, nu):
    """Stresses under a Hertz line contact with Coulomb traction (plane strain).

    docs/model.md Appendix A.2 (McEwen, Phil. Mag. 40 (1949); Smith & Liu, J. Appl. Mech. 20 (1953);
    Johnson, Contact Mechanics (1985) §7.1): p(x) = p0 √(1 − x²/b²), q = μp in +x on the
    body, σ_z(x,0) = −p, τ_xz(x,0) = −q. With m, n of :func:`_mn`, D = m² + n², q0 = μp0,

        normal:     σ_x = −(p0/b)[m(1 + (z²+n²)/D) − 2z],  σ_z = −(p0/b) m (1 − (z²+n²)/D),
                    τ_xz = −(p0/b) n (m²−z²)/D;
        tangential: σ_x = (q0/b)[n(2 − (z²−m²)/D) − 2x],   σ_z = −(q0/b) n (m²−z²)/D,
                    τ_xz = −(q0/b)[m(1 + (z²+n²)/D) − 2z];

    σ_y = ν(σ_x + σ_z), τ_yz = τ_xy = 0. ``x``, ``z`` [m] broadcast; returns (6, *shape).
    Finite everywhere including the surface and the contact edges (at x = ±b, z = 0, where
    D = 0, the ratio terms are multiplied by m = n = 0 and are set to 0). Surface values:
    σ_x(x,0) = −p − 2μp0 x/b inside, −2μp0 (x − sign(x)√(x²−b²))/b outside.
    """
    x, z = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(z, dtype=float))
    if np.any(z < 0):
        raise ValueError("z must be non-negative (depth into the body)")
    if b <= 0:
        raise ValueError(f"semi-width b = {b} must be positive")
    m, n = _mn(x, z, b)
    D = m * m + n * n
    ok = D > 0
    r1 = np.divide(z * z + n * n, D, out=np.zeros_like(D), where=ok)   # (z²+n²)/D
    r2 = np.divide(m * m - z * z, D, out=np.zeros_like(D), where=ok)   # (m²−z²)/D
    c, q0 = p0 / b, mu * p0 / b
    out = np.zeros((6, *x.shape))
    shear_like = m * (1.0 + r1) - 2.0 * z
    out[0] = -c * shear_like + q0 * (n * (2.0 + r2) - 2.0 * x)   # (z²−m²)/D = −r2
    out[2] = -c * m * (1.0 - r1) - q0 * n * r2
    out[4] = -c * n * r2 - q0 * shear_like
    out[1] = nu * (out[0] + out[2])
    return out


# --- elliptical contact ---------------------------------------------------------------------

#: Σ' 1/|n|³ over the square lattice Z² \ {0} = 4 ζ(3/2) β(3/2) (Zucker 1974).
_LATTICE_S3 = 9.033621683100950


def _hertz_ellipse_spectrum(grid: Grid, a_x: float, a_y: float, p0: float) -> np.ndarray:
    """Half spectrum, in the ``rfft2`` (sum) normalisation, of the periodic Hertz pressure
    p = p0 √(1 − x²/a_x² − y²/a_y²) centred on x = y = 0 of ``grid``: the exact continuous
    Fourier transform 2π a_x a_y p0 j1(K)/K, K = √((k_x a_x)² + (k_y a_y)²) (spherical Bessel
    j1; the hemisphere transform scaled to the ellipse), divided by the cell area and shifted
    to the grid's origin at index (nx/2, ny/2). Feeding the exact transform (instead of the
    FFT of samples) removes the O(h^{3/2}) quadrature error of the √-edge of the pressure; what
    is left is the truncation at the Nyquist wavenumber, whose field decays as e^{−πz/Δ}."""
    K = np.sqrt((grid.kx * a_x) ** 2 + (grid.ky * a_y) ** 2)
    Ks = np.where(K > 0, K, 1.0)
    j1_over_K = np.where(K > 0, spherical_jn(1, Ks) / Ks, 1.0 / 3.0)
    spec = (2.0 * math.pi * a_x * a_y * p0 / (grid.dx * grid.dy)) * j1_over_K
    # the grid's x = 0 sits at index nx//2: shift by (−1)^i phase factors, exactly
    i = np.arange(grid.nx)[:, None]
    j = np.arange(grid.ny // 2 + 1)[None, :]
    phase = np.exp(2j * math.pi * (i * (grid.nx // 2) / grid.nx + j * (grid.ny // 2) / grid.ny))
    return spec * np.conj(phase)


class EllipticalContactField:
    """Macro stress field of a Hertz elliptical contact with Coulomb traction μp in +x.

    Semi-axes ``a_x`` (rolling direction x) and ``a_y`` (across), peak pressure ``p0``, Poisson
    ratio ``nu``. The field is linear in μ, σ = σ_N + μ σ_T, so both parts are kept and any
    (signed) friction coefficient is applied at evaluation: :meth:`stress` ``(x, y, z, mu)``.
    Depth layers are computed on first use (or up front with ``z``) and cached.

    No closed form exists off the axis for an ellipse with friction, so each layer is computed
    once (docs/model.md §4.2, "a non-periodic DC-FFT"): the Appendix A.1 kernels
    (:class:`HalfSpaceStress`) on a square periodic window of side L = ``pad`` · max(a_x, a_y)
    with ``points`` nodes per semi-axis, fed with the exact Fourier transform of the Hertz
    pressure (:func:`_hertz_ellipse_spectrum`); then

    * the mean-mode field U, which the periodic kernels exclude, is added: σ_zz = −p̄ and
      σ_xz = −q̄ (equilibrium of the x, y-independent part), σ_xx = σ_yy = −(1+2ν)p̄/2 (the
      surface identity σ_xx + σ_yy = −(1+2ν)p of A.1 averaged over the period and split equally
      by the square lattice), p̄ = F/L², q̄ = μp̄, F = 2πa_x a_y p0/3;
    * the leading error of the periodic images, linear in z, is removed: the images add
      Δσ_xx = Δσ_yy = −(1+ν) F S₃ z/(2π L³), from ∂_z(σ_r + σ_θ) = −(F/π)(1+ν)/r³ of the
      Boussinesq field (Johnson 1985 eq. 3.20) at the surface, summed over the square lattice
      (S₃ = Σ' |n|⁻³ = 9.0336).

    What remains is O(F z³/L⁵) (and O(F z r²/L⁵) off the axis) from the images and the
    Nyquist cut-off of the pressure, which decays as e^{−πz/Δ} (Δ = a/``points``).

    Accuracy (defaults: 32 points, pad 16; tests/test_hertz_field.py): on the axis of a circular
    contact against Johnson eq. 3.45, ≤ 1.4e-4 p0 for 2Δ ≤ z ≤ 3a (2.7e-3 without the image
    correction; 3.9e-3 at z = 3a with pad 8). Shallower than 2Δ the pressure's √-edge is not
    resolved: 1.1e-3 p0 on the axis at z = 0 and up to ~3e-2 p0 next to the contact edge
    (3e-3 p0 inside r < 0.8a at the surface; these fall as Δ^{3/2} in the interior). Between
    the nodes the cubic-spline interpolation adds ≤ 4e-4 p0 at z = 2Δ, < 1e-5 p0 below 0.15a.

    Cost per layer: 12 inverse FFTs of the (pad·points·max/a_x) × (pad·points·max/a_y) window
    (512² for a circle: about 1 s for 15 layers on one core, in chunks of ≤ 64 MB), and 12 spline
    coefficient planes of the kept box |x| ≤ x_max, |y| ≤ y_max (default 3 a_x, 3 a_y:
    2 × 6 × 201² × 8 B = 3.9 MB per layer with the defaults). The window grows with a_y/a_x
    (square window, x resolved by a_x): for long ellipses lower ``points``/``pad`` or, in the
    middle of the contact, use :func:`line_contact_stress` (which σ_zz, σ_xz approach as
    (a_x/a_y)², σ_xx, σ_yy only as a_x/a_y: at the centre σ_xx(0) = −p0[2ν + (1−2ν)
    a_y/(a_x+a_y)]).

    Evaluation: cubic B-spline interpolation of the prefiltered nodes (exact at the nodes).
    Points given as an outer product — x, y, z each varying along its own axis, like
    ``(x[None, :, None], y[None, None, :], z[:, None, None])`` — take a separable path (two
    sparse products for all layers and components: 128² points × 15 layers in ~0.05 s);
    scattered points go through ``scipy.ndimage.map_coordinates`` (~4x slower).
    """

    def __init__(self, a_x: float, a_y: float, p0: float, nu: float, z=None, *,
                 points: int = 32, pad: float = 16.0, x_max: float | None = None,
                 y_max: float | None = None, image_correction: bool = True):
        if not (a_x > 0 and a_y > 0):
            raise ValueError(f"semi-axes {a_x}, {a_y} must be positive")
        if points < 4 or pad < 4:
            raise ValueError("need points >= 4 per semi-axis and pad >= 4")
        if not -1.0 < nu < 0.5:
            raise ValueError(f"Poisson ratio {nu} outside (-1, 0.5)")
        self.a_x, self.a_y, self.p0, self.nu = float(a_x), float(a_y), float(p0), float(nu)
        self.image_correction = bool(image_correction)
        L = pad * max(a_x, a_y)
        nx = next_5smooth(math.ceil(L / (a_x / points)))
        ny = next_5smooth(math.ceil(L / (a_y / points)))
        nx += nx % 2  # even sizes put x = 0 on a node
        ny += ny % 2
        self.grid = grid = Grid(nx, ny, L, L)
        self.x_max = min(3.0 * a_x if x_max is None else float(x_max), L / 4)
        self.y_max = min(3.0 * a_y if y_max is None else float(y_max), L / 4)
        # the nodes within (x_max, y_max) plus 4 for the spline support
        ix = np.flatnonzero(np.abs(grid.x) <= self.x_max + 4 * grid.dx)
        iy = np.flatnonzero(np.abs(grid.y) <= self.y_max + 4 * grid.dy)
        self._kx = slice(ix[0], ix[-1] + 1)
        self._ky = slice(iy[0], iy[-1] + 1)
        self.x = grid.x[self._kx].copy()     # kept nodes [m]
        self.y = grid.y[self._ky].copy()
        self._P = -_hertz_ellipse_spectrum(grid, a_x, a_y, p0)   # σ_zz(0) = −p
        self._zero = np.zeros_like(self._P)
        self.load = 2.0 * math.pi * a_x * a_y * p0 / 3.0
        self.z = np.zeros(0)                                  # layers computed so far
        # spline coefficients of the normal and unit-tangential parts, laid out
        # (part, x node, component, layer, y node) so that the x contraction needs no copy
        self._coef = np.zeros((2, ix.size, 6, 0, iy.size))
        self._index: dict[float, int] = {}
        if z is not None:
            self._ensure(np.unique(np.asarray(z, dtype=float)))

    # ---- precomputation ----------------------------------------------------------------------
    def _ensure(self, zs: np.ndarray) -> np.ndarray:
        """Compute the layers of ``zs`` not cached yet; return the indices of all of ``zs``."""
        new = np.unique([float(z) for z in zs if float(z) not in self._index])
        if new.size:
            if not (np.all(np.isfinite(new)) and np.all(new >= 0)):
                raise ValueError("depths must be finite and non-negative")
            self._coef = np.concatenate([self._coef, self._layers(new)], axis=3)
            for z in new:
                self._index[float(z)] = len(self._index)
            self.z = np.concatenate([self.z, new])
        return np.array([self._index[float(z)] for z in zs], dtype=int)

    def _layers(self, z: np.ndarray) -> np.ndarray:
        """Spline coefficients (2, nx_kept, 6, len(z), ny_kept) of the normal part and the unit
        tangential part (μ = 1) on the depths ``z``."""
        g, nu, F = self.grid, self.nu, self.load
        L = g.lx
        pbar = F / (L * L)
        vals = np.empty((2, 6, z.size, self.x.size, self.y.size))
        chunk = max(1, int(64e6 // (6 * 8 * g.nx * g.ny)))     # ≤ 64 MB of full window
        for k0 in range(0, z.size, chunk):
            layers = slice(k0, min(k0 + chunk, z.size))
            hs = HalfSpaceStress(g, z[layers], nu)
            for part, (P, T) in enumerate(((self._P, self._zero), (self._zero, self._P))):
                s = hs.stresses(P, T)
                vals[part, :, layers] = s[:, :, self._kx, self._ky]
        # mean-mode field U, excluded by the periodic kernels
        vals[0, 2] -= pbar
        vals[0, 0] -= 0.5 * (1 + 2 * nu) * pbar
        vals[0, 1] -= 0.5 * (1 + 2 * nu) * pbar
        vals[1, 4] -= pbar
        if self.image_correction:   # remove the images' leading Δσ_xx = Δσ_yy = −d(z)
            d = (1 + nu) * F * _LATTICE_S3 / (2 * math.pi * L**3) * z
            vals[0, 0] += d[:, None, None]
            vals[0, 1] += d[:, None, None]
        for idx in np.ndindex(vals.shape[:3]):
            ndimage.spline_filter(vals[idx], order=3, output=vals[idx], mode="mirror")
        return np.ascontiguousarray(vals.transpose(0, 3, 1, 2, 4))

    # ---- evaluation --------------------------------------------------------------------------
    def _index_coords(self, x, y):
        if np.any(np.abs(x) > self.x_max * (1 + 1e-12)) or \
                np.any(np.abs(y) > self.y_max * (1 + 1e-12)):
            raise ValueError(f"points outside |x| <= {self.x_max:g}, |y| <= {self.y_max:g} m "
                             "(set x_max, y_max)")
        return (x - self.x[0]) / self.grid.dx, (y - self.y[0]) / self.grid.dy

    @staticmethod
    def _bspline_matrix(u: np.ndarray, n: int) -> sparse.csr_matrix:
        """Rows of cubic B-spline weights at fractional node indices ``u`` (interior)."""
        i = np.floor(u).astype(int)
        t = u - i
        w = np.stack([(1 - t) ** 3, 3 * t**3 - 6 * t**2 + 4, -3 * t**3 + 3 * t**2 + 3 * t + 1,
                      t**3], axis=1) / 6.0
        cols = i[:, None] + np.arange(-1, 3)[None, :]
        rows = np.repeat(np.arange(u.size), 4)
        return sparse.csr_matrix((w.ravel(), (rows, cols.ravel())), shape=(u.size, n))

    def stress(self, x, y, z, mu: float = 0.0) -> np.ndarray:
        """Stresses (6, *shape) at the points (x, y, z) (broadcast) for friction ``mu`` (traction
        μp in +x on the body; negative μ reverses it)."""
        xa, ya, za = (np.asarray(a, dtype=float) for a in (x, y, z))
        shape = np.broadcast_shapes(xa.shape, ya.shape, za.shape)
        nd = len(shape)
        xa, ya, za = (a.reshape((1,) * (nd - a.ndim) + a.shape) for a in (xa, ya, za))
        owners = [[j for j in range(nd) if a.shape[j] > 1] for a in (xa, ya, za)]
        axes = [j for o in owners for j in o]
        if all(len(o) <= 1 for o in owners) and len(set(axes)) == len(axes):
            return self._stress_outer(xa, ya, za, owners, shape, mu)
        xb, yb, zb = (np.broadcast_to(a, shape).ravel() for a in (xa, ya, za))
        u, v = self._index_coords(xb, yb)
        zs, inv = np.unique(zb, return_inverse=True)
        li = self._ensure(zs)
        out = np.empty((6, xb.size))
        for k, layer in enumerate(li):
            pts = np.flatnonzero(inv == k)
            coords = np.stack([u[pts], v[pts]])
            for c in range(6):
                val = ndimage.map_coordinates(self._coef[0, :, c, layer], coords, order=3,
                                              mode="mirror", prefilter=False)
                if mu:
                    val += mu * ndimage.map_coordinates(self._coef[1, :, c, layer], coords,
                                                        order=3, mode="mirror",
                                                        prefilter=False)
                out[c, pts] = val
        return out.reshape(6, *shape)

    def _stress_outer(self, xa, ya, za, owners, shape, mu):
        """Separable evaluation on the outer product of 1-D x, y, z."""
        xs, ys, zs = xa.ravel(), ya.ravel(), za.ravel()
        u, v = self._index_coords(xs, ys)
        li = self._ensure(zs)
        nxk, nyk = self.x.size, self.y.size
        nz = zs.size
        if np.array_equal(li, np.arange(li[0], li[0] + nz)):
            li = slice(li[0], li[0] + nz)                              # a view, no copy
        Wx = self._bspline_matrix(u, nxk)
        Wy = self._bspline_matrix(v, nyk)
        A = Wx @ self._coef[0][:, :, li].reshape(nxk, -1)              # (nqx, 6·nz·nyk)
        if mu:
            A += mu * (Wx @ self._coef[1][:, :, li].reshape(nxk, -1))
        R = (Wy @ A.reshape(-1, nyk).T).T.reshape(xs.size, 6, nz, ys.size)
        idx = []
        for n, own in zip((nz, xs.size, ys.size), (owners[2], owners[0], owners[1]),
                          strict=True):
            ar = np.arange(n)
            if own:
                ar = ar.reshape([n if j == own[0] else 1 for j in range(len(shape))])
            else:
                ar = ar.reshape((1,) * len(shape))
            idx.append(ar)
        iz, ixq, iyq = idx
        return np.moveaxis(R, 1, 0)[:, ixq, iz, iyq]


def elliptical_contact_stress(x, y, z, a_x, a_y, p0, mu, nu, **options):
    """Stresses (6, *shape) of the Hertz ellipse (semi-axes a_x along x, a_y along y, peak
    pressure p0) with traction μp in +x, at points (x, y, z) (broadcast): builds an
    :class:`EllipticalContactField` (``options`` go to its constructor) and evaluates it. For
    many evaluations of one contact build the object once instead."""
    return EllipticalContactField(a_x, a_y, p0, nu, **options).stress(x, y, z, mu)
