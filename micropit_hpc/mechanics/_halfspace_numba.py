"""Compiled layer spectra of the half-space stresses (Numba): one pass per depth layer of
:meth:`micropit_hpc.mechanics.halfspace.HalfSpaceStress.stresses`.

Per mode, the six kernels A_c, B_c of the module docstring of :mod:`.halfspace` are formed from
the traction spectra P̂, T̂x, T̂y and the angle factors a, b on the fly, and the layer's spectra
σ̂_c(z_k) = E_k A_c + F_k B_c written straight into the inverse transform's input buffer: the
NumPy reference builds and stores the twelve kernel planes once per call and then combines them
per layer, which in a streamed load cycle (one layer per call, docs/performance.md §9) costs
about as much as the layer's transforms. The same formulas; the products are grouped
otherwise, so the two agree to round-off (tests/test_kernels.py). The Nyquist row and column
of an even axis are symmetrised in the same pass. ``parallel=False``: every core
already runs an MPI rank. ``cache=True``: compiled once per machine. The helpers are plain
``@njit`` functions, inlined by LLVM: Numba's IR-level ``inline="always"`` made the first
compilation take minutes (docs/performance.md §10).
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, fastmath={"contract"})
def _mode(pr, pi, xr, xi, yr, yi, aa, bb, nu, e, f):
    """E A_c + F B_c, c = 0 … 5, of one mode at the angle factors aa, bb, as (real, imaginary)
    pairs: the complex formulas of :func:`~micropit_hpc.mechanics.halfspace._kernel_spectra`
    (P̂ = pr + i pi, T̂x = xr + i xi, T̂y = yr + i yi) written out in real arithmetic, which
    skips the products with the zero parts of i a and i b."""
    qr = pr + aa * xi + bb * yi              # Q = P − i(a Tx + b Ty)
    qi = pi - aa * xr - bb * yr
    a2 = aa * aa
    b2 = bb * bb
    ab = aa * bb
    n2 = 2.0 * nu
    return (e * (a2 * pr + 2.0 * aa * xi + n2 * b2 * qr) - f * a2 * qr,
            e * (a2 * pi - 2.0 * aa * xr + n2 * b2 * qi) - f * a2 * qi,
            e * (b2 * pr + 2.0 * bb * yi + n2 * a2 * qr) - f * b2 * qr,
            e * (b2 * pi - 2.0 * bb * yr + n2 * a2 * qi) - f * b2 * qi,
            e * pr + f * qr,
            e * pi + f * qi,
            e * yr + f * bb * qi,
            e * yi - f * bb * qr,
            e * xr + f * aa * qi,
            e * xi - f * aa * qr,
            e * (ab * pr + bb * xi + aa * yi - n2 * ab * qr) - f * ab * qr,
            e * (ab * pi - bb * xr - aa * yr - n2 * ab * qi) - f * ab * qi)


@njit(cache=True, fastmath={"contract"})
def _add(v, w):
    return (v[0] + w[0], v[1] + w[1], v[2] + w[2], v[3] + w[3], v[4] + w[4], v[5] + w[5],
            v[6] + w[6], v[7] + w[7], v[8] + w[8], v[9] + w[9], v[10] + w[10], v[11] + w[11])


@njit(cache=True, fastmath={"contract"})
def layer_spectra(P, Tx, Ty, has_ty, a, b, nu, E, F, nyq_row, nyq_col, out):
    """out[c] = E A_c + F B_c (c in Voigt order xx, yy, zz, yz, xz, xy) for the kernels of
    P̂, T̂x, T̂y (``has_ty`` False: T̂y = 0) at the angle factors a, b; all (nx, m), ``out``
    (6, nx, m) complex. On the Nyquist row ``nyq_row`` and column ``nyq_col`` of an even axis
    (−1: none) the kernels are averaged over ±a (±b; over both at the corner), as
    :meth:`~micropit_hpc.mechanics.halfspace.HalfSpaceStress._symmetrise` does for the NumPy
    path: the spectra are linear in the kernels, so the average of the spectra at the flipped
    factors is the spectra of the averaged kernels."""
    nx, m = P.shape
    has_row, has_col = nyq_row >= 0, nyq_col >= 0
    for i in range(nx):
        for j in range(m):
            _store(out, i, j, _point(P, Tx, Ty, has_ty, a, b, nu, E, F, i, j, False, False))
    # the Nyquist lines, overwritten (a second pass keeps the first free of branches)
    if has_row:
        for j in range(m):
            _store(out, nyq_row, j, _point(P, Tx, Ty, has_ty, a, b, nu, E, F, nyq_row, j,
                                           True, has_col and j == nyq_col))
    if has_col:
        for i in range(nx):
            if not (has_row and i == nyq_row):
                _store(out, i, nyq_col, _point(P, Tx, Ty, has_ty, a, b, nu, E, F, i, nyq_col,
                                               False, True))


@njit(cache=True, fastmath={"contract"})
def _point(P, Tx, Ty, has_ty, a, b, nu, E, F, i, j, flip_a, flip_b):
    """The 12 parts of mode (i, j), averaged over ±a (``flip_a``) and ±b (``flip_b``)."""
    p = P[i, j]
    tx = Tx[i, j]
    ty = Ty[i, j] if has_ty else 0.0j
    pr, pi, xr, xi, yr, yi = p.real, p.imag, tx.real, tx.imag, ty.real, ty.imag
    aa = a[i, j]
    bb = b[i, j]
    e = E[i, j]
    f = F[i, j]
    v = _mode(pr, pi, xr, xi, yr, yi, aa, bb, nu, e, f)
    if not (flip_a or flip_b):
        return v
    sa = -1.0 if flip_a else 1.0
    sb = -1.0 if flip_b else 1.0
    v = _add(v, _mode(pr, pi, xr, xi, yr, yi, sa * aa, sb * bb, nu, e, f))
    w = 0.5
    if flip_a and flip_b:              # the corner: all four sign pairs
        v = _add(v, _mode(pr, pi, xr, xi, yr, yi, -aa, bb, nu, e, f))
        v = _add(v, _mode(pr, pi, xr, xi, yr, yi, aa, -bb, nu, e, f))
        w = 0.25
    return (w * v[0], w * v[1], w * v[2], w * v[3], w * v[4], w * v[5],
            w * v[6], w * v[7], w * v[8], w * v[9], w * v[10], w * v[11])


@njit(cache=True)
def _store(out, i, j, v):
    out[0, i, j] = complex(v[0], v[1])
    out[1, i, j] = complex(v[2], v[3])
    out[2, i, j] = complex(v[4], v[5])
    out[3, i, j] = complex(v[6], v[7])
    out[4, i, j] = complex(v[8], v[9])
    out[5, i, j] = complex(v[10], v[11])
