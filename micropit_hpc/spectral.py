"""Periodic grids and pre-planned real 2-D FFTs: the spectral machinery every stage shares.

Layout: a field on the window is a float64 array of shape ``(nx, ny)``; axis 0 is x (rolling,
the direction a slab decomposition splits), axis 1 is y (across rolling). Its real transform
has shape ``(nx, ny//2 + 1)`` (numpy's ``rfft2`` convention: forward unnormalised, basis
e^{+i(k_x x + k_y y)}, inverse divides by nx·ny). Wavenumbers are angular [rad/m].

Transforms are planned once per shape (pyFFTW, one thread per rank) and cached; without pyFFTW
the same API falls back to ``numpy.fft`` (about 10x slower, docs/hpc.md §2). Grid sizes that factor
into 2, 3 and 5 only (5-smooth) are fastest; any size works.

Planner (``MICROPIT_FFTW_PLANNER``): ``auto`` (default) plans each serial transform from this
machine's FFTW wisdom file (:func:`wisdom_path`) when the file holds it — the ``FFTW_MEASURE``
plan measured once per machine and shape by ``python -m micropit_hpc.spectral plan N …``
(:func:`plan_wisdom`), 10–30 % faster per transform — and with ``FFTW_ESTIMATE`` otherwise.
Both choose the same algorithm in every process that reads the same file, so results stay
bitwise identical on any number of ranks and across runs (docs/contact.md, "FFT planning and
reproducibility"). ``estimate`` ignores the wisdom; ``measure`` (or ``patient``) times
candidate algorithms in every process, which may pick different ones in different processes,
whose results then differ in the last bits.
"""

from __future__ import annotations

import math
import os
import platform
import sys
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from micropit_hpc.errors import MicropitError

try:  # pragma: no cover - which branch runs depends on the installation
    import pyfftw
    import pyfftw.builders
except ImportError:  # pragma: no cover
    pyfftw = None

__all__ = ["Grid", "RealFFT2", "fourier_shift", "have_pyfftw", "interleave", "is_5smooth",
           "next_5smooth", "rfft_plan", "to_material_frame"]


def have_pyfftw() -> bool:
    """True when pyFFTW is importable (the fast path)."""
    return pyfftw is not None


def is_5smooth(n: int) -> bool:
    """True if n > 0 has no prime factor above 5 (FFT-friendly)."""
    if n < 1:
        return False
    for p in (2, 3, 5):
        while n % p == 0:
            n //= p
    return n == 1


def next_5smooth(n: int) -> int:
    """The smallest 5-smooth integer ≥ n."""
    m = max(int(n), 1)
    while not is_5smooth(m):
        m += 1
    return m


@dataclass(frozen=True)
class Grid:
    """A uniform periodic grid of ``nx × ny`` points over a window ``lx × ly`` [m].

    Points sit at x_i = (i − nx/2)·dx, so the window is centred on x = 0 (likewise y).
    """

    nx: int
    ny: int
    lx: float
    ly: float

    def __post_init__(self):
        if self.nx < 2 or self.ny < 1:
            raise ValueError(f"grid {self.nx} x {self.ny}: need nx >= 2 and ny >= 1 points")
        if not (math.isfinite(self.lx) and math.isfinite(self.ly)
                and self.lx > 0 and self.ly > 0):
            raise ValueError(f"grid lengths {self.lx} x {self.ly} m must be positive and finite")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.nx, self.ny)

    @property
    def spectral_shape(self) -> tuple[int, int]:
        return (self.nx, self.ny // 2 + 1)

    @property
    def dx(self) -> float:
        return self.lx / self.nx

    @property
    def dy(self) -> float:
        return self.ly / self.ny

    @property
    def x(self) -> np.ndarray:
        """x coordinates of the grid rows [m], shape (nx,)."""
        return (np.arange(self.nx) - self.nx // 2) * self.dx

    @property
    def y(self) -> np.ndarray:
        """y coordinates of the grid columns [m], shape (ny,)."""
        return (np.arange(self.ny) - self.ny // 2) * self.dy

    @cached_property
    def kx(self) -> np.ndarray:
        """Angular wavenumbers along x, shape (nx, 1) [rad/m]."""
        return (2 * np.pi * np.fft.fftfreq(self.nx, self.dx))[:, None]

    @cached_property
    def ky(self) -> np.ndarray:
        """Angular wavenumbers along y (non-negative half), shape (1, ny//2+1) [rad/m]."""
        return (2 * np.pi * np.fft.rfftfreq(self.ny, self.dy))[None, :]

    @cached_property
    def kappa(self) -> np.ndarray:
        """|k| = √(k_x² + k_y²), shape (nx, ny//2+1); 0 at the mean mode."""
        return np.sqrt(self.kx**2 + self.ky**2)

    @cached_property
    def rfft_weight(self) -> np.ndarray:
        """Multiplicity of each half-spectrum column in the full spectrum (1 or 2), shape
        (1, ny//2+1): sums over the half spectrum weighted by this equal full-spectrum sums."""
        w = np.full(self.ny // 2 + 1, 2.0)
        w[0] = 1.0
        if self.ny % 2 == 0:
            w[-1] = 1.0
        return w[None, :]


PLANNERS = {"auto": "FFTW_ESTIMATE", "estimate": "FFTW_ESTIMATE", "measure": "FFTW_MEASURE",
            "patient": "FFTW_PATIENT"}


def planner_name() -> str:
    """``MICROPIT_FFTW_PLANNER`` (default ``auto``), checked against :data:`PLANNERS`."""
    name = os.environ.get("MICROPIT_FFTW_PLANNER", "auto").strip().lower()
    if name not in PLANNERS:
        raise MicropitError(f"MICROPIT_FFTW_PLANNER={name!r}: allowed {', '.join(PLANNERS)}")
    return name


def planner_flag() -> str:
    """The FFTW planner flag of a transform planned without wisdom (``auto``: ESTIMATE)."""
    return PLANNERS[planner_name()]


def wisdom_path() -> str:
    """This machine's FFTW wisdom file: ``MICROPIT_FFTW_WISDOM``, else
    ``$XDG_CACHE_HOME/micropit_hpc/fftw-wisdom-<host>-<arch>.txt`` (``~/.cache`` without
    XDG_CACHE_HOME). Wisdom is only valid on the machine that measured it, hence the host in
    the name (as Numba's cache is kept per machine)."""
    given = os.environ.get("MICROPIT_FFTW_WISDOM")
    if given:
        return given
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    host = "".join(c if c.isalnum() or c in "-_." else "_" for c in platform.node()) or "host"
    return os.path.join(base, "micropit_hpc", f"fftw-wisdom-{host}-{platform.machine()}.txt")


_wisdom_read: list[str] = []        # the wisdom files this process has imported


def _import_wisdom() -> bool:
    """Import this machine's wisdom file into FFTW once per process (and file); True when
    FFTW knows some double-precision wisdom from it."""
    path = wisdom_path()
    if path in _wisdom_read:
        return True
    try:
        with open(path, "rb") as fh:
            text = fh.read()
    except OSError:
        return False
    ok = bool(text) and bool(pyfftw.import_wisdom((text, b"", b""))[0])
    if ok:
        _wisdom_read.append(path)
    return ok


def plan_wisdom(shapes, batch: int | None = None) -> str:
    """Measure the ``FFTW_MEASURE`` plans of the real 2-D transform pair (forward and inverse,
    as :class:`RealFFT2` lays them out) for each shape of ``shapes`` and merge them into this
    machine's wisdom file (:func:`wisdom_path`, written whole to a temporary file and renamed,
    so a reader never sees half a file); returns its path. Run once per machine (``python -m
    micropit_hpc.spectral plan 256 512 1024``): from then on every process plans those
    transforms from the file (:class:`RealFFT2`, planner ``auto``). FFTW_MEASURE times
    candidate algorithms on this machine (Frigo & Johnson, Proc. IEEE 93 (2005) 216–231)."""
    if pyfftw is None:  # pragma: no cover
        raise MicropitError("planning FFTW wisdom needs pyFFTW")
    path = wisdom_path()
    _import_wisdom()
    for shape in shapes:
        RealFFT2(shape, batch, flag="FFTW_MEASURE")
    try:
        with open(path, "rb") as fh:      # what another process added meanwhile
            pyfftw.import_wisdom((fh.read(), b"", b""))
    except OSError:
        pass
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "wb") as fh:
        fh.write(pyfftw.export_wisdom()[0])
    os.replace(tmp, path)
    _wisdom_read.clear()
    return path


class RealFFT2:
    """Pre-planned real 2-D FFT pair over the last two axes of arrays of one shape.

    ``batch`` leading transforms are done in one call (e.g. 6 stress components × N_z layers).
    ``forward`` and ``inverse`` return new arrays unless ``out`` is given; the inverse is
    normalised (numpy convention).
    """

    def __init__(self, shape: tuple[int, int], batch: int | None = None, threads: int = 1,
                 flag: str | None = None):
        """``flag``: the FFTW planner flag; None: the planner of ``MICROPIT_FFTW_PLANNER``
        (``auto``: the machine's measured plan where its wisdom file holds it, ESTIMATE
        otherwise; :attr:`from_wisdom` says which)."""
        self.shape = (int(shape[0]), int(shape[1]))
        self.from_wisdom = False
        self.batch = batch
        lead = () if batch is None else (int(batch),)
        self.real_shape = (*lead, *self.shape)
        self.spectral_shape = (*lead, self.shape[0], self.shape[1] // 2 + 1)
        if pyfftw is not None:
            a = pyfftw.empty_aligned(self.real_shape, dtype="float64")
            c = pyfftw.empty_aligned(self.spectral_shape, dtype="complex128")
            c2 = pyfftw.empty_aligned(self.spectral_shape, dtype="complex128")
            a2 = pyfftw.empty_aligned(self.real_shape, dtype="float64")

            def plan(*flags):
                return (pyfftw.FFTW(a, c, axes=(-2, -1), direction="FFTW_FORWARD",
                                    flags=flags, threads=threads),
                        pyfftw.FFTW(c2, a2, axes=(-2, -1), direction="FFTW_BACKWARD",
                                    flags=flags, threads=threads))

            if flag is None and planner_name() == "auto" and _import_wisdom():
                try:        # both plans from the measured wisdom, or neither
                    self._fwd, self._inv = plan("FFTW_MEASURE", "FFTW_DESTROY_INPUT",
                                                "FFTW_WISDOM_ONLY")
                    self.from_wisdom = True
                except RuntimeError:        # this shape is not in the file
                    pass
            if not self.from_wisdom:
                self._fwd, self._inv = plan(flag or planner_flag(), "FFTW_DESTROY_INPUT")
        else:  # pragma: no cover
            self._fwd = self._inv = None

    def forward(self, a: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """rfft2 of ``a`` (shape ``real_shape``)."""
        if self._fwd is None:  # pragma: no cover
            r = np.fft.rfft2(a)
        else:
            self._fwd.input_array[...] = a
            self._fwd.execute()
            r = self._fwd.output_array
        if out is None:
            return r.copy()
        out[...] = r
        return out

    def inverse(self, c: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """irfft2 of ``c`` (shape ``spectral_shape``), normalised."""
        if self._inv is None:  # pragma: no cover
            r = np.fft.irfft2(c, s=self.shape)
            if out is None:
                return r
            out[...] = r
            return out
        self._inv.input_array[...] = c
        self._inv.execute()
        r = self._inv.output_array
        if out is None:
            out = np.empty(self.real_shape)
        np.multiply(r, 1.0 / (self.shape[0] * self.shape[1]), out=out)
        return out


    @property
    def real_input(self) -> np.ndarray:
        """The forward transform's own input buffer (``real_shape``): a caller that writes the
        field here can run :meth:`convolve` without the copy in."""
        if self._fwd is None:  # pragma: no cover
            if not hasattr(self, "_in"):
                self._in = np.empty(self.real_shape)
            return self._in
        return self._fwd.input_array

    def interleaved(self, transfer: np.ndarray) -> np.ndarray:
        """A real transfer function (``spectral_shape``) laid out for :meth:`convolve`: divided
        by the transform size nx·ny (so that the inverse needs no normalising pass) and each
        value twice, for the real and the imaginary part of its mode."""
        return interleave(transfer, self.shape[0] * self.shape[1])

    def convolve(self, transfer: np.ndarray, a: np.ndarray | None = None) -> np.ndarray:
        """irfft2(rfft2(a) · T) for the real transfer function T that ``transfer`` holds in the
        layout of :meth:`interleaved` (T/(nx·ny), each value twice), as a view of the inverse's
        output buffer (overwritten by the next transform of this plan). ``a`` None: the field
        already stands in :attr:`real_input`. The contact solver's inner loop: no copy out, no
        normalising pass, and the product one real multiply over the spectrum's floats.
        """
        if a is not None:
            self.real_input[...] = a
        if self._fwd is None:  # pragma: no cover
            spec = np.fft.rfft2(self._in) * transfer[..., ::2]
            return np.fft.irfft2(spec, s=self.shape) * (self.shape[0] * self.shape[1])
        self._fwd.execute()
        np.multiply(self._fwd.output_array.view(np.float64), transfer,
                    out=self._inv.input_array.view(np.float64))
        self._inv.execute()
        return self._inv.output_array

    @property
    def spectral_input(self) -> np.ndarray:
        """The inverse transform's own input buffer (``spectral_shape``): a caller that writes
        the spectrum here runs :meth:`execute_inverse` without the copy in."""
        if self._inv is None:  # pragma: no cover
            if not hasattr(self, "_spec_in"):
                self._spec_in = np.empty(self.spectral_shape, dtype=complex)
            return self._spec_in
        return self._inv.input_array

    def execute_inverse(self) -> np.ndarray:
        """irfft2 of :attr:`spectral_input` **unnormalised** (the caller folds 1/(nx·ny) into
        what it writes there), as a view of the output buffer (overwritten by the next inverse
        of this plan; the input buffer is destroyed)."""
        if self._inv is None:  # pragma: no cover
            return np.fft.irfft2(self._spec_in, s=self.shape) * (self.shape[0] * self.shape[1])
        self._inv.execute()
        return self._inv.output_array


def interleave(transfer: np.ndarray, size: int) -> np.ndarray:
    """A real transfer function on half-spectrum modes, divided by the transform ``size``
    nx·ny and each value twice, for the real and the imaginary part of its mode: the layout in
    which one real multiply over a spectrum's floats applies it and the inverse needs no
    normalising pass (:meth:`RealFFT2.convolve`,
    :meth:`~micropit_hpc.parallel.slab.Slab.filtered`)."""
    return np.repeat(np.asarray(transfer, dtype=float) / size, 2, axis=-1)


_PLANS: dict[tuple, RealFFT2] = {}


def rfft_plan(shape: tuple[int, int], batch: int | None = None) -> RealFFT2:
    """The cached :class:`RealFFT2` of this shape and batch (planned on first use)."""
    key = (int(shape[0]), int(shape[1]), batch)
    plan = _PLANS.get(key)
    if plan is None:
        plan = _PLANS[key] = RealFFT2(shape, batch)
    return plan


def discrete_gaussian(grid: Grid, variance: float) -> np.ndarray:
    """Transfer function on ``grid``'s half spectrum, shape (nx, ny//2+1), of the discrete
    Gaussian of ``variance`` [m²] along each axis (Lindeberg, "Scale-space for discrete signals",
    IEEE Trans. PAMI 12 (1990) 234: T(n; t) = e^(−t) I_n(t), t = variance/Δ²):

        Ĝ(k_x, k_y) = exp(−t_x (1 − cos k_x Δx)) · exp(−t_y (1 − cos k_y Δy)).

    Unlike the sampled continuous transfer exp(−|k|² variance / 2), which is cut at the Nyquist
    wave and whose kernel then has negative lobes (13 % of its mass at a variance of 0.2 cells²,
    enough to put tension into a non-negative pressure map's average), its kernel is positive
    at every cell size and has the exact variance; Ĝ(0) = 1, and as Δ → 0 it tends to
    exp(−|k|² variance / 2) (1 − cos kΔ → (kΔ)²/2)."""
    tx, ty = variance / grid.dx ** 2, variance / grid.dy ** 2
    return (np.exp(-tx * (1.0 - np.cos(grid.kx * grid.dx)))
            * np.exp(-ty * (1.0 - np.cos(grid.ky * grid.dy))))


def fourier_shift(spectrum: np.ndarray, grid: Grid, sx: float, sy: float = 0.0,
                  cols: slice | None = None) -> np.ndarray:
    """Half spectrum of the field translated by (sx, sy): f(x − sx, y − sy), exactly (periodic).

    ``cols``: the k_y columns that ``spectrum`` holds (a slab's part of the half spectrum).

    Multiplies by e^{−i k_x s_x} e^{−i k_y s_y}. On an even-sized axis the Nyquist wave cannot
    tell +k from −k; its factor is taken as cos(k s), the symmetric band-limited choice, which
    keeps the field real and is exact for whole-cell shifts.
    """
    px = np.exp(-1j * grid.kx * sx)
    py = np.exp(-1j * grid.ky * sy)
    if grid.nx % 2 == 0:
        px[grid.nx // 2] = px[grid.nx // 2].real
    if grid.ny % 2 == 0:
        py[:, -1] = py[:, -1].real
    phase = px * (py if cols is None else py[:, cols])
    return spectrum * phase


def to_material_frame(field: np.ndarray, shift: float, dx: float) -> np.ndarray:
    """F(X + shift) on the periodic grid, by linear interpolation along x (axis 0): a
    window-frame field seen at material point X of a body that has slipped by ``shift``.

    Conserves the sum of ``field`` exactly (each value is split between two neighbours with
    weights adding to one) and keeps every value within the field's own bounds: a pressure
    in [0, p_lim] stays in [0, p_lim]. This is why pressures, tractions and wear go into the
    material frame by this interpolation and not by :func:`fourier_shift`, whose exact
    band-limited shift of a capped plateau or a contact edge rings (negative pressures and
    overshoots above p_lim; docs/contact.md, "The stress history").
    """
    s = shift / dx
    q = math.floor(s)
    f = s - q
    if f == 0.0:
        return np.roll(field, -q, axis=0)
    # (1 − f) F[i + q] + f F[i + q + 1], i + q taken modulo n: each product written by two
    # slices of ``field`` straight into its place (no rolled copies), the same operations
    # element by element as rolling first, so the same bits
    n = field.shape[0]
    k, k1 = q % n, (q + 1) % n
    out = np.empty(field.shape, np.result_type(field, f))
    right = np.empty_like(out)
    np.multiply(field[k:], 1.0 - f, out=out[:n - k])
    np.multiply(field[:k], 1.0 - f, out=out[n - k:])
    np.multiply(field[k1:], f, out=right[:n - k1])
    np.multiply(field[:k1], f, out=right[n - k1:])
    return np.add(out, right, out=out)


def main(argv=None) -> int:
    """``python -m micropit_hpc.spectral plan N [N ...] [--batch B [B ...]]``: measure the plans
    of the N × N (or NxM) transforms into this machine's wisdom file (:func:`plan_wisdom`),
    for each batch B (default 1 and 6: the single transforms of the contact solvers and the
    six-plane batches of the stress layers; 1 means no batch)."""
    import argparse
    import time

    ap = argparse.ArgumentParser(prog="python -m micropit_hpc.spectral",
                                 description="Measure FFTW plans once per machine.")
    sub = ap.add_subparsers(dest="command", required=True)
    p = sub.add_parser("plan", help="measure the plans of these grid sizes into the wisdom file")
    p.add_argument("sizes", nargs="+", help="N (an N x N grid) or NxM")
    p.add_argument("--batch", type=int, nargs="+", default=[1, 6],
                   help="transforms per call to plan (default: 1 and 6; 1 means no batch)")
    args = ap.parse_args(argv)
    shapes = []
    for size in args.sizes:
        nx, _, ny = size.lower().partition("x")
        shapes.append((int(nx), int(ny or nx)))
    t0 = time.perf_counter()
    for batch in args.batch:
        if batch < 1:
            ap.error(f"--batch {batch}: give a number of transforms ≥ 1")
        path = plan_wisdom(shapes, None if batch == 1 else batch)
    print(f"FFTW_MEASURE plans of {', '.join(args.sizes)} in {path} "
          f"({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
