"""Compiled layer combination of the half-space stresses (Numba): one pass of
:meth:`micropit_hpc.mechanics.halfspace.HalfSpaceStress.stresses` per depth layer.

σ̂_c(z_k) = E_k A_c + F_k B_c for the six Voigt components c, written straight into the
inverse transform's input buffer: the same products and sum per value as the NumPy reference
(``contract`` lets LLVM fuse them into one multiply-add, a round-off difference;
tests/test_halfspace.py compares the two). ``parallel=False``: every core already runs an MPI
rank. ``cache=True``: compiled once per machine.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True, fastmath={"contract"})
def combine(A, B, E, F, out):
    """out[c] = A[c]·E + B[c]·F for c = 0..5: ``A``, ``B``, ``out`` (6, nx, m) complex as
    float views (6, nx, 2m); ``E``, ``F`` (nx, m) real, each value applying to both floats of
    its mode."""
    nc, nx, m2 = out.shape
    for c in range(nc):
        for i in range(nx):
            for j in range(m2):
                h = j >> 1
                out[c, i, j] = A[c, i, j] * E[i, h] + B[c, i, j] * F[i, h]
