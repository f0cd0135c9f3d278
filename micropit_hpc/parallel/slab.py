"""Level-2 parallelism: one work item's window over the ranks of its group (docs/hpc.md §2).

The window's x rows are split into contiguous slabs, one per rank of the group; depth is never
split. Every (x, y, z) field of the item — the stress history, the Dang Van results, the damage
columns — lives only on its slab, so a window too large for one rank's memory fits on several.
The 2-D fields (heights, pressure, wear, pits) are small and replicated.

* FFTs: real 2-D transforms by mpi4py-fft's slab decomposition (``PFFT``, physical space
  distributed along x, spectral space along k_y: rank r owns the half-spectrum columns
  :attr:`Slab.cols`), with pyFFTW as its serial backend and our planner flag (mpi4py-fft's own
  FFTW backend frees FFTW's shared state at exit while pyFFTW plans are alive: a segfault at
  interpreter shutdown, reproduced with 27² windows). A one-rank group takes the same code
  path with the serial pre-planned pyFFTW transform (mpi4py-fft costs 1.3–1.8× raw pyFFTW
  on one rank, docs/hpc.md §2).
* The contact solvers use the same rows (docs/hpc.md §2): :meth:`Slab.filtered` is their
  convolution, :meth:`Slab.sums` their reductions (allgathered, added in rank order: the same
  on every rank).
* (x, y, z) fields: a PETSc DMDA with the same x ownership (sizes (n_y, n_x, N_z), processes
  (1, R, 1)), whose vectors wrap the slab arrays without a copy (``Vec.createWithArray``);
  :meth:`Slab.gather` brings a field to the group root in natural order through the DMDA's
  natural vector.

Results equal those of one rank to round-off (the distributed transform sums in another order;
tests/test_restart_mpi.py checks 1e-12 relative with ranks_per_item = 2).
"""

from __future__ import annotations

import numpy as np

from micropit_hpc.errors import MicropitError
from micropit_hpc.spectral import Grid, interleave, planner_flag, rfft_plan

__all__ = ["Reductions", "Slab"]


def _op_max():
    try:
        from mpi4py import MPI
    except ImportError:  # SerialComm ignores the operation
        return None
    return MPI.MAX


class Slab:
    """The x-slab of ``grid`` owned by this rank of ``comm`` (a work item's group).

    ``rows``: this rank's x rows (physical space); ``cols``: its k_y columns of the half
    spectrum (spectral space); ``counts``: the row counts of every rank, in rank order.
    """

    def __init__(self, comm, grid: Grid, n_layers: int):
        self.comm, self.grid, self.n_layers = comm, grid, int(n_layers)
        size = comm.size
        nx, ny = grid.shape
        nyh = ny // 2 + 1
        self._pfft = None
        self._da = None
        if size == 1:
            self.rows, self.cols = slice(0, nx), slice(0, nyh)
            self._fwd = rfft_plan(grid.shape)
            self._inv6 = rfft_plan(grid.shape, batch=6)
            self.counts = (nx,)
            return
        if nx < size or nyh < size:
            raise MicropitError(
                f"a {nx} x {ny} window cannot be split over {size} ranks per work item: each "
                f"rank needs at least one x row and one k_y column (ranks_per_item ≤ "
                f"{min(nx, nyh)}; or use a larger window.nx / window.ny)")
        try:
            from mpi4py_fft import PFFT
        except ImportError as e:
            raise MicropitError(
                "ranks_per_item > 1 needs mpi4py-fft (Debian: python3-mpi4py-fft; "
                f"scripts/setup.sh installs it): {e}") from None
        self._pfft = PFFT(comm, grid.shape, axes=(0, 1), dtype=float, grid=(-1, 1),
                           backend="pyfftw", planner_effort=planner_flag())
        self.rows = self._pfft.local_slice(False)[0]
        self.cols = self._pfft.local_slice(True)[1]
        self.counts = tuple(comm.allgather(self.rows.stop - self.rows.start))
        self._real = np.empty(self._pfft.shape(False))
        self._spec = np.empty(self._pfft.shape(True), dtype=complex)

    # ---- layout ------------------------------------------------------------------------------
    @property
    def nx_local(self) -> int:
        return self.rows.stop - self.rows.start

    @property
    def local_shape(self) -> tuple[int, int, int]:
        """Shape of this rank's part of an (N_z, n_x, n_y) field."""
        return (self.n_layers, self.nx_local, self.grid.ny)

    @property
    def is_root(self) -> bool:
        return self.comm.rank == 0

    # ---- transforms --------------------------------------------------------------------------
    def forward(self, f_local: np.ndarray) -> np.ndarray:
        """Half spectrum (columns :attr:`cols`) of the field whose rows :attr:`rows` are
        ``f_local`` (numpy ``rfft2`` convention, unnormalised). Collective."""
        if self._pfft is None:
            return self._fwd.forward(f_local)
        self._real[...] = f_local
        return self._pfft.forward(self._real, self._spec.copy(), normalize=False)

    def filtered(self, f_local: np.ndarray, transfer: np.ndarray) -> np.ndarray:
        """The rows :attr:`rows` of irfft2(rfft2(f) · T): a periodic convolution of the field
        whose rows are ``f_local`` by the real transfer function T, whose k_y columns
        :attr:`cols` ``transfer`` holds laid out as :meth:`interleaved` makes them
        (normalisation folded in, each value twice), as a view of the slab's buffer
        (overwritten by its next transform). The contact solver's inner loop
        (:class:`~micropit_hpc.lubrication.dry.ElasticHalfSpaces`). Collective."""
        if self._pfft is None:
            return self._fwd.convolve(transfer, f_local)
        self._real[...] = f_local
        spec = self._pfft.forward(self._real, self._spec, normalize=False)
        spec_f = spec.view(np.float64)
        np.multiply(spec_f, transfer, out=spec_f)
        return self._pfft.backward(spec, self._real, normalize=False)

    def interleaved(self, transfer: np.ndarray) -> np.ndarray:
        """The columns :attr:`cols` of a whole-window real transfer function (``(nx, ny//2+1)``)
        laid out for :meth:`filtered`: divided by nx·ny and each value twice (real and
        imaginary part of its mode)."""
        return interleave(np.asarray(transfer)[:, self.cols], self.grid.nx * self.grid.ny)

    def inverse6(self, c: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Six inverse transforms (normalised): local spectra ``c`` (6, n_x, len(cols)) into
        the local rows ``out`` (6, len(rows), n_y). Collective."""
        if self._pfft is None:
            return self._inv6.inverse(c, out=out)
        for k in range(6):
            self._spec[...] = c[k]
            self._pfft.backward(self._spec, self._real, normalize=True)
            out[k] = self._real
        return out

    # ---- replicated 2-D fields and reductions ------------------------------------------------
    def allgather_rows(self, local: np.ndarray) -> np.ndarray:
        """The whole (n_x, ...) array on every rank from each rank's rows. Collective."""
        if self.comm.size == 1:
            return local
        return np.concatenate(self.comm.allgather(np.ascontiguousarray(local)), axis=0)

    def max(self, value: float) -> float:
        """The largest ``value`` over the group (exact). Collective."""
        if self.comm.size == 1:
            return float(value)
        return float(self.comm.allreduce(float(value), op=_op_max()))

    def sum(self, value: float) -> float:
        """The sum of ``value`` over the group, added in rank order (the same on every rank).
        Collective."""
        return float(self.sums((value,))[0])

    def min(self, value: float) -> float:
        """The smallest ``value`` over the group (exact). Collective."""
        return -self.max(-float(value))

    def sums(self, values) -> tuple:
        """The sums over the group of each of ``values`` (a few numbers), each added in rank
        order as :meth:`sum` does, in one collective call: the same on every rank, whatever
        the timing. One rank: ``values`` unchanged (numpy scalars stay numpy scalars, so a
        one-rank solver computes the very numbers of the serial code). Collective."""
        values = tuple(values)
        if self.comm.size == 1:
            return values
        mine = np.array([float(v) for v in values])
        parts = np.empty((self.comm.size, mine.size))
        self.comm.Allgather(mine, parts)          # the buffer form: no pickling
        out = []
        for i in range(mine.size):
            total = 0.0
            for part in parts[:, i].tolist():
                total += part
            out.append(total)
        return tuple(out)

    def bcast(self, obj):
        """The group root's ``obj`` on every rank. Collective."""
        return obj if self.comm.size == 1 else self.comm.bcast(obj, root=0)

    # ---- (x, y, z) fields through the DMDA ---------------------------------------------------
    def _dmda(self):
        if self._da is None:
            from micropit_hpc.parallel.petsc import require_petsc

            PETSc = require_petsc("ranks_per_item > 1")
            nx, ny = self.grid.shape
            self._da = PETSc.DMDA().create(
                dim=3, dof=1, sizes=(ny, nx, self.n_layers), proc_sizes=(1, self.comm.size, 1),
                ownership_ranges=((ny,), self.counts, (self.n_layers,)), stencil_width=0,
                comm=self.comm)
            (y0, y1), (x0, x1), (z0, z1) = self._da.getRanges()
            if (x0, x1) != (self.rows.start, self.rows.stop) or (y0, y1) != (0, ny):
                raise MicropitError(f"DMDA ownership x {x0}:{x1} differs from the FFT slab "
                                    f"{self.rows.start}:{self.rows.stop}")
        return self._da

    def vec(self, local: np.ndarray):
        """A DMDA vector over this rank's part ``local`` (N_z, rows, n_y) of a field, sharing
        its memory (no copy)."""
        from micropit_hpc.parallel.petsc import require_petsc

        PETSc = require_petsc("ranks_per_item > 1")
        da = self._dmda()
        arr = np.ascontiguousarray(local, dtype=float)
        if arr.shape != self.local_shape:
            raise MicropitError(f"slab field of shape {arr.shape}, expected {self.local_shape}")
        v = PETSc.Vec().createWithArray(arr.reshape(-1), size=(arr.size, PETSc.DECIDE),
                                        comm=self.comm)
        v.setDM(da)
        return v

    def gather(self, local: np.ndarray) -> np.ndarray | None:
        """The whole (N_z, n_x, n_y) field on the group root (None elsewhere), in natural
        order through the DMDA. Collective."""
        if self.comm.size == 1:
            return local
        from micropit_hpc.parallel.petsc import require_petsc

        PETSc = require_petsc("ranks_per_item > 1")
        da = self._dmda()
        g = self.vec(local)
        natural = da.createNaturalVec()
        da.globalToNatural(g, natural)
        scatter, whole = PETSc.Scatter.toZero(natural)
        scatter.scatter(natural, whole, False, PETSc.Scatter.Mode.FORWARD)
        out = None
        if self.is_root:
            out = whole.getArray().copy().reshape(self.n_layers, *self.grid.shape)
        for obj in (scatter, whole, natural, g):
            obj.destroy()
        return out


class Reductions:
    """The reductions of a solver that works either on a slab's rows or on the whole window
    (``slab`` None, or a one-rank slab): over the slab's group they are the slab's (sums in
    rank order, so every rank gets the same numbers and takes the same branches); otherwise
    the values pass unchanged, and the solver computes exactly what the serial code computes
    (:mod:`micropit_hpc.lubrication.dry`, :mod:`micropit_hpc.lubrication.mixed`)."""

    def __init__(self, slab: Slab | None):
        self.slab = None if slab is None or slab.comm.size == 1 else slab

    def sums(self, *values):
        return values if self.slab is None else self.slab.sums(values)

    def max(self, value):
        return value if self.slab is None else self.slab.max(value)

    def min(self, value):
        return value if self.slab is None else self.slab.min(value)

    def any(self, mask: np.ndarray) -> bool:
        local = bool(mask.any())
        return local if self.slab is None else self.slab.max(float(local)) > 0.0
