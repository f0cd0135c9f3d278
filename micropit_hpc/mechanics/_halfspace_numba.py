"""Compiled layer spectra of the half-space stresses (Numba): one pass per depth layer of
:meth:`micropit_hpc.mechanics.halfspace.HalfSpaceStress.stresses`.

Per mode, the six kernels A_c, B_c of the module docstring of :mod:`.halfspace` are formed from
the traction spectra P̂, T̂x, T̂y and the angle factors a, b on the fly, and the layer's spectra
σ̂_c(z_k) = E_k A_c + F_k B_c written straight into the inverse transform's input buffer: the
NumPy reference builds and stores the twelve kernel planes once per call and then combines them
per layer, which in a streamed load cycle (one layer per call, docs/performance.md §9) costs
about as much as the layer's transforms. The same formulas; the products are grouped
otherwise, so the two agree to round-off (tests/test_kernels.py). The Nyquist row and column
are then overwritten by the caller from its symmetrised kernels. ``parallel=False``: every core
already runs an MPI rank. ``cache=True``: compiled once per machine.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, fastmath={"contract"})
def layer_spectra(P, Tx, Ty, has_ty, a, b, nu, E, F, out):
    """out[c] = E A_c + F B_c (c in Voigt order xx, yy, zz, yz, xz, xy) for the kernels of
    P̂, T̂x, T̂y (``has_ty`` False: T̂y = 0) at the angle factors a, b; all (nx, m), ``out``
    (6, nx, m) complex."""
    nx, m = P.shape
    for i in range(nx):
        for j in range(m):
            p = P[i, j]
            tx = Tx[i, j]
            ty = Ty[i, j] if has_ty else 0.0j
            aa = a[i, j]
            bb = b[i, j]
            e = E[i, j]
            f = F[i, j]
            iatx = 1j * aa * tx
            ibty = 1j * bb * ty
            q = p - iatx - ibty                      # Q = P − i(a Tx + b Ty)
            a2 = aa * aa
            b2 = bb * bb
            ab = aa * bb
            out[0, i, j] = e * (a2 * p - 2.0 * iatx + 2.0 * nu * b2 * q) - f * a2 * q
            out[1, i, j] = e * (b2 * p - 2.0 * ibty + 2.0 * nu * a2 * q) - f * b2 * q
            out[2, i, j] = e * p + f * q
            out[3, i, j] = e * ty - f * 1j * bb * q
            out[4, i, j] = e * tx - f * 1j * aa * q
            out[5, i, j] = (e * (ab * p - 1j * (bb * tx + aa * ty) - 2.0 * nu * ab * q)
                            - f * ab * q)
