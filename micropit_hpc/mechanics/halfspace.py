"""Subsurface stresses of an elastic half-space under periodic surface tractions (the micro field).

docs/model.md §4.2 and Appendix A.1: for a surface mode e^{i(αx+βy)} with ζ = √(α²+β²) > 0 and
E = e^{−ζz}, the stresses are closed-form in z (Boussinesq–Cerruti in the partial Fourier domain).
With the angle factors a = α/ζ, b = β/ζ, t = ζz and

    Q = P̂ − i(a T̂x + b T̂y)        (so that tr σ̂ = 2(1+ν) E Q, the A.1 trace check),

the six A.1 kernels regroup exactly into

    σ̂_xx = E[a²P̂ − 2ia T̂x + (2νb² − a²t) Q]
    σ̂_yy = E[b²P̂ − 2ib T̂y + (2νa² − b²t) Q]
    σ̂_zz = E[P̂ + t Q]
    σ̂_yz = E[T̂y − i b t Q]
    σ̂_xz = E[T̂x − i a t Q]
    σ̂_xy = E[ab P̂ − i(b T̂x + a T̂y) − ab(2ν + t) Q],

i.e. every component is E·A_c + (ζz E)·B_c with six layer-independent spectra A_c, B_c. Only the
two real per-layer factors e^{−ζz_k} and ζz_k e^{−ζz_k} are stored; a call builds A, B once and
then two multiplies and one add per layer (tests/test_halfspace.py checks the regrouping against
the printed A.1 formulas term by term).

Inputs are the half spectra (``rfft2``, numpy convention, see :mod:`micropit_hpc.spectral`) of
the surface values σ_zz(x,y,0) = −p, σ_xz(x,y,0) = −q_x, σ_yz(x,y,0) = −q_y. The mean mode
(α = β = 0) is excluded — it belongs to the macro field — so every returned layer has zero mean.

Nyquist modes. On an even-sized axis the grid cannot tell +k_N from −k_N: the sampled traction is
the symmetric (cosine) band-limited interpolant, half at +k_N and half at −k_N. The kernels are
therefore replaced on the Nyquist row (and column) by their average over the two signs, which
removes the parts odd in α (in β) there. The output spectra are then exactly Hermitian, so the
real inverse transform neither discards nor invents anything, and the result equals the exact
stress field of the band-limited traction at the grid points.

Cost per call: 3 forward FFTs (``from_tractions``) and 6·N_z inverse real 2-D FFTs, done as N_z
batched transforms of 6 planes through one cached pyFFTW plan (``rfft_plan(shape, batch=6)``).
"""

from __future__ import annotations

import math

import numpy as np

from micropit_hpc.compiled import resolve
from micropit_hpc.spectral import Grid, rfft_plan

__all__ = ["DEFAULT_KERNEL", "STRESS_CHUNK_BYTES", "VOIGT", "HalfSpaceStress", "depth_layers",
           "history_chunk_layers"]

#: Voigt order of the stress components in every (6, ...) stress block.
VOIGT = ("xx", "yy", "zz", "yz", "xz", "xy")

#: The memory budget of one chunk of a body's stress history on one rank [bytes]
#: (:func:`history_chunk_layers`): the load cycle streams the history through depth in chunks of
#: layers no larger than this (one layer at least), docs/performance.md "Streamed stresses".
STRESS_CHUNK_BYTES = 64 * 2 ** 20

#: The implementation of the per-layer spectra that :meth:`HalfSpaceStress.stresses` uses
#: when none is given: "auto" (compiled where Numba can be imported, else NumPy), "numba" or
#: "numpy" (:mod:`micropit_hpc.compiled`). A module-level switch for whole runs.
DEFAULT_KERNEL = "auto"


def history_chunk_layers(n_layers: int, steps: int, points: int,
                         budget: float = STRESS_CHUNK_BYTES) -> int:
    """Depth layers per chunk of a stress history of ``steps`` time steps on ``points`` grid
    points (this rank's): the most whose history, steps × 6 × 8 bytes per point and layer, fits
    in ``budget`` bytes, at least 1 and at most ``n_layers``, then evened out over the chunks
    that number needs (15 layers at 4 per chunk: 4 chunks of 4, 4, 4, 3)."""
    n_layers = int(n_layers)
    per_layer = 48.0 * max(1, int(steps)) * max(1, int(points))
    fit = max(1, min(n_layers, int(budget // per_layer) if math.isfinite(budget) else n_layers))
    chunks = -(-n_layers // fit)
    return -(-n_layers // chunks)


def depth_layers(n_layers: int, z_max: float, spacing: str = "quadratic") -> np.ndarray:
    """Depths of the stress layers [m], z_0 = 0 (the surface) to z_{N−1} = z_max.

    ``"quadratic"`` (docs/model.md §4.2 default, 15 layers to z_max = 0.25 b):
    z_k = z_max (k/(N_z−1))², dense near the surface where the rough-contact stresses live;
    ``"uniform"``: z_k = z_max k/(N_z−1). ``n_layers = 1`` gives the surface only.
    """
    n = int(n_layers)
    if n < 1:
        raise ValueError(f"n_layers = {n_layers}: need at least one layer")
    if not (np.isfinite(z_max) and z_max >= 0):
        raise ValueError(f"z_max = {z_max}: must be finite and non-negative")
    if n == 1:
        return np.zeros(1)
    s = np.arange(n) / (n - 1)
    if spacing == "quadratic":
        return z_max * s**2
    if spacing == "uniform":
        return z_max * s
    raise ValueError(f"spacing {spacing!r}: use 'quadratic' or 'uniform'")


def _kernel_spectra(P, Tx, Ty, a, b, nu, A, B):
    """Fill the layer-independent spectra A_c, B_c (Voigt order, shape (6, *P.shape)) so that
    σ̂_c(z) = e^{−ζz} A_c + ζz e^{−ζz} B_c (docs/model.md Appendix A.1, regrouped as in the module
    docstring). ``Ty`` may be None (no transverse traction). Works on any broadcastable slices;
    ``A`` and ``B`` must not alias the inputs."""
    a2 = a * a
    b2 = b * b
    ab = a * b
    # Q = P − i(a Tx + b Ty); S = −i(a Tx + b Ty) is built in B[2] to save a temporary
    iaTx = np.multiply(Tx, a)
    iaTx *= 1j                                    # i a Tx
    if Ty is not None:
        ibTy = np.multiply(Ty, b)
        ibTy *= 1j                                # i b Ty
    Q = B[2]
    np.subtract(P, iaTx, out=Q)
    if Ty is not None:
        Q -= ibTy
    # zz: A = P, B = Q (already in place)
    A[2] = P
    # xz, yz: A = T, B = −i a t Q / t = −i a Q
    A[4] = Tx
    np.multiply(Q, a, out=B[4])
    B[4] *= -1j
    if Ty is None:
        A[3] = 0.0
    else:
        A[3] = Ty
    np.multiply(Q, b, out=B[3])
    B[3] *= -1j
    # xx: A = a²P − 2iaTx + 2νb²Q, B = −a²Q
    np.multiply(P, a2, out=A[0])
    A[0] -= 2.0 * iaTx
    A[0] += (2.0 * nu * b2) * Q
    np.multiply(Q, -a2, out=B[0])
    # yy: A = b²P − 2ibTy + 2νa²Q, B = −b²Q
    np.multiply(P, b2, out=A[1])
    if Ty is not None:
        A[1] -= 2.0 * ibTy
    A[1] += (2.0 * nu * a2) * Q
    np.multiply(Q, -b2, out=B[1])
    # xy: A = abP − i(bTx + aTy) − 2ν ab Q, B = −ab Q
    np.multiply(P, ab, out=A[5])
    ibTx = np.multiply(Tx, b)
    ibTx *= 1j
    A[5] -= ibTx
    if Ty is not None:
        iaTy = np.multiply(Ty, a)
        iaTy *= 1j
        A[5] -= iaTy
    A[5] -= (2.0 * nu * ab) * Q
    np.multiply(Q, -ab, out=B[5])


class HalfSpaceStress:
    """Micro stress field of a half-space under the fluctuating part of periodic surface
    tractions, on the depth layers ``z`` of a periodic :class:`~micropit_hpc.spectral.Grid`.

    docs/model.md §4.2 and Appendix A.1 (kernels of [T03] in the partial Fourier domain; checked by
    equilibrium, boundary values, the A.1 trace relation, the Boussinesq point-load limit
    (Johnson 1985 eq. 3.20) and the McEwen/Smith–Liu line-contact field, see the tests).

    Results are float64 arrays of shape (6, N_z, nx, ny), Voigt order (xx, yy, zz, yz, xz, xy),
    tension positive. The mean mode is excluded: each layer has zero mean.

    ``slab`` (:class:`~micropit_hpc.parallel.slab.Slab`): with a group of several ranks, this
    rank keeps the kernels of its k_y columns only and returns its x rows only,
    (6, N_z, len(slab.rows), ny); the transforms are mpi4py-fft's. Default: one rank, the whole
    window, pyFFTW.

    Memory: two real per-layer factors (2·N_z·nx·(ny/2+1) float64: 34 MB at 256² × 32 layers,
    135 MB at 512² × 32) plus 9 complex half-spectrum planes of scratch (the layer's six spectra,
    on one rank the batch plan's own input buffer, and three traction spectra), 13 more once
    the NumPy reference path runs (its twelve kernel planes and one temporary), and the cached
    plans' buffers; the inverse transforms go layer by layer through one batch-6 plan, so no
    (6·N_z)-plane spectral buffer is ever held (one batch of 6·N_z planes was also slower:
    benchmarks/README.md).
    """

    def __init__(self, grid: Grid, z, nu: float, slab=None):
        z = np.atleast_1d(np.asarray(z, dtype=float))
        if z.ndim != 1 or not np.all(np.isfinite(z)) or np.any(z < 0):
            raise ValueError("z must be a 1-D array of finite, non-negative depths")
        if not -1.0 < nu < 0.5:
            raise ValueError(f"Poisson ratio {nu} outside (-1, 0.5)")
        self.grid = grid
        self.z = z
        self.nu = float(nu)
        if slab is None:
            from micropit_hpc.parallel import SerialComm
            from micropit_hpc.parallel.slab import Slab

            slab = Slab(SerialComm(), grid, z.size)
        self.slab = slab
        cols = slab.cols
        nx, nyh = grid.spectral_shape
        zeta = grid.kappa[:, cols]
        ncols = zeta.shape[1]
        mask = zeta > 0
        inv = np.divide(1.0, zeta, out=np.zeros_like(zeta), where=mask)
        # angle factors α/ζ, β/ζ (0 at the excluded mean mode)
        self._a = np.ascontiguousarray(np.broadcast_to(grid.kx, zeta.shape) * inv)
        self._b = np.ascontiguousarray(np.broadcast_to(grid.ky[:, cols], zeta.shape) * inv)
        # per-layer factors e^{−ζz} and ζz e^{−ζz}; zero at the mean mode (excluded)
        t = zeta[None] * z[:, None, None]
        self._E = np.exp(-t)
        if cols.start == 0:
            self._E[:, 0, 0] = 0.0
        self._F = t * self._E
        # one rank: the inverse transforms read the combination straight from the batch plan's
        # input buffer, their 1/(nx·ny) folded into the layer factors (no normalising pass)
        self._plan = rfft_plan(grid.shape, batch=6) if slab.comm.size == 1 else None
        if self._plan is not None:
            self._E /= grid.nx * grid.ny
            self._F /= grid.nx * grid.ny
        # Nyquist row/column of even axes: kernels are averaged over ±k there (module docstring)
        self._nyq_row = nx // 2 if grid.nx % 2 == 0 else None
        last = nyh - 1 - cols.start
        self._nyq_col = last if grid.ny % 2 == 0 and 0 <= last < ncols else None
        # scratch (the NumPy path's kernel planes: _reference_planes, made on first use)
        self._C = (np.empty((6, nx, ncols), dtype=complex) if self._plan is None
                   else self._plan.spectral_input)
        self._spec = np.empty((3, nx, ncols), dtype=complex)
        self._planes = None

    @property
    def serial(self) -> bool:
        """True when the whole window is on this rank (a one-rank slab): :meth:`layer_fields`
        is available."""
        return self._plan is not None

    @property
    def n_layers(self) -> int:
        return self.z.size

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """Shape of a result: (6, N_z, rows of the slab, ny) — (6, N_z, nx, ny) on one rank."""
        return (6, self.z.size, self.slab.nx_local, self.grid.ny)

    def _reference_planes(self):
        """(A, B, T): the twelve kernel planes of the NumPy path and its one temporary plane,
        allocated on first use (the compiled path forms the kernels on the fly and needs
        none: 13 complex planes, about 110 MB at 1024²)."""
        if self._planes is None:
            shape = self._a.shape
            self._planes = (np.empty((6, *shape), dtype=complex),
                            np.empty((6, *shape), dtype=complex), np.empty(shape, dtype=complex))
        return self._planes

    def _symmetrise(self, P, Tx, Ty):
        """Replace A, B on the Nyquist row/column by their average over ±α (±β)."""
        (A, B, _), a, b, nu = self._reference_planes(), self._a, self._b, self.nu
        r, c = self._nyq_row, self._nyq_col

        def average(sl, flips):
            acc_a = np.zeros((6, *a[sl].shape), dtype=complex)
            acc_b = np.zeros_like(acc_a)
            ta, tb = np.empty_like(acc_a), np.empty_like(acc_a)
            for sa, sb in flips:
                _kernel_spectra(P[sl], Tx[sl], None if Ty is None else Ty[sl],
                                sa * a[sl], sb * b[sl], nu, ta, tb)
                acc_a += ta
                acc_b += tb
            A[(slice(None), *sl)] = acc_a / len(flips)
            B[(slice(None), *sl)] = acc_b / len(flips)

        # the corner (both Nyquist) is averaged over all four sign pairs
        if r is not None:
            cols = slice(None, c) if c is not None else slice(None)
            average((r, cols), ((1, 1), (-1, 1)))
        if c is not None:
            rows = (np.arange(self.grid.nx) if r is None
                    else np.delete(np.arange(self.grid.nx), r))
            average((rows, c), ((1, 1), (1, -1)))
        if r is not None and c is not None:
            average(((r,), (c,)), ((1, 1), (-1, 1), (1, -1), (-1, -1)))

    def stresses(self, P_hat, Tx_hat, Ty_hat=None, out=None, layers=None,
                 kernel: str | None = None) -> np.ndarray:
        """Stresses (6, N_z, nx, ny) of the fluctuating surface tractions (docs/model.md A.1).

        ``P_hat``, ``Tx_hat``, ``Ty_hat``: half spectra (``rfft2``, shape (nx, ny//2+1); on a
        slab of several ranks only its columns ``slab.cols``) of
        σ_zz(0) = −p, σ_xz(0) = −q_x, σ_yz(0) = −q_y; ``Ty_hat=None`` means no q_y. Their mean
        modes are ignored. ``layers``: optional indices (or a slice) into :attr:`z` to compute
        only those layers (to bound memory on large grids); the result then has
        ``len(layers)`` layers. ``out``: optional float64 array of the result's shape.
        ``kernel``: each layer's spectra formed in one compiled pass or with NumPy from the
        kernels stored once per call (:mod:`micropit_hpc.compiled`; None:
        :data:`DEFAULT_KERNEL`); the two agree to round-off.
        """
        idx = self._layer_indices(layers)
        shape = (6, idx.size, self.slab.nx_local, self.grid.ny)
        if out is None:
            out = np.empty(shape)
        elif out.shape != shape or out.dtype != np.float64:
            raise ValueError(f"out must be float64 of shape {shape}")
        plan = self._plan
        for kk, C in self._layer_spectra(P_hat, Tx_hat, Ty_hat, idx, kernel):
            if plan is None:
                self.slab.inverse6(C, out[:, kk])
            else:
                out[:, kk] = plan.execute_inverse()
        return out

    def layer_fields(self, P_hat, Tx_hat, Ty_hat=None, layers=None,
                     kernel: str | None = None):
        """The layers of :meth:`stresses` one at a time, without its copy: yields (kk, σ) for
        each of ``layers`` in turn (kk its index among them), σ (6, nx, ny) a view of the
        batch plan's output, valid until the next layer is made. The whole window on one
        rank only (a slab of several ranks has no such buffer: use :meth:`stresses`); the
        same numbers as :meth:`stresses`."""
        if not self.serial:
            raise ValueError("layer_fields needs the whole window on one rank (a one-rank slab)")
        idx = self._layer_indices(layers)
        for kk, _ in self._layer_spectra(P_hat, Tx_hat, Ty_hat, idx, kernel):
            yield kk, self._plan.execute_inverse()

    def _layer_indices(self, layers) -> np.ndarray:
        idx = np.arange(self.z.size)
        return idx if layers is None else idx[layers]

    def _layer_spectra(self, P_hat, Tx_hat, Ty_hat, idx, kernel):
        """Yields (kk, C) for each layer idx[kk]: C the six spectra of that layer (docs/model.md
        A.1, C_c = E A_c + ζz E B_c), in the buffer the inverse transforms read."""
        ss = self._a.shape
        for name, s in (("P_hat", P_hat), ("Tx_hat", Tx_hat), ("Ty_hat", Ty_hat)):
            if s is not None and np.shape(s) != ss:
                raise ValueError(f"{name} has shape {np.shape(s)}, expected {ss}")
        compiled = resolve(DEFAULT_KERNEL if kernel is None else kernel,
                           "mechanics._halfspace_numba", "HalfSpaceStress.stresses")
        if compiled is None:   # the reference: the twelve kernel planes once per call
            A, B, T = self._reference_planes()
            _kernel_spectra(P_hat, Tx_hat, Ty_hat, self._a, self._b, self.nu, A, B)
            if self._nyq_row is not None or self._nyq_col is not None:
                self._symmetrise(P_hat, Tx_hat, Ty_hat)
        C = self._C
        nyq = tuple(-1 if n is None else n for n in (self._nyq_row, self._nyq_col))
        for kk, k in enumerate(idx):
            E, F = self._E[k], self._F[k]
            if compiled is not None:   # C_c = E A_c + ζz E B_c, kernels formed on the fly
                compiled.layer_spectra(P_hat, Tx_hat, P_hat if Ty_hat is None else Ty_hat,
                                       Ty_hat is not None, self._a, self._b, self.nu, E, F,
                                       *nyq, C)
            else:
                for c in range(6):
                    np.multiply(A[c], E, out=C[c])
                    np.multiply(B[c], F, out=T)
                    C[c] += T
            yield kk, C

    def spectra(self, p, qx, qy=None):
        """Half spectra (P̂, T̂x, T̂y) of σ_zz(0) = −p, σ_xz(0) = −q_x, σ_yz(0) = −q_y (views of
        internal buffers, overwritten by the next call); T̂y is None when ``qy`` is None."""
        spec = self._spec
        for i, f in enumerate((p, qx, qy)):
            if f is None:
                continue
            if np.shape(f) != self.grid.shape:
                raise ValueError(f"traction of shape {np.shape(f)}, expected {self.grid.shape}")
            np.negative(self.slab.forward(f[self.slab.rows]), out=spec[i])
        return spec[0], spec[1], (None if qy is None else spec[2])

    def from_tractions(self, p, qx, qy=None, out=None) -> np.ndarray:
        """Stresses (6, N_z, nx, ny) of the fluctuations of pressure ``p`` (compression
        positive) and friction tractions ``qx``, ``qy`` on the body (in +x, +y), all of shape
        (nx, ny): 2–3 forward FFTs then :meth:`stresses`."""
        return self.stresses(*self.spectra(p, qx, qy), out=out)
