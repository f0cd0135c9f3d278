"""A rough surface on a uniform grid: the :class:`Topography` container (docs/model.md §3).

``heights[i, j]`` [m] is the height of the point ``origin + (i·dx, j·dy)``, measured outward from
the body (a peak is positive, docs/model.md §1); axis 0 is x (rolling), axis 1 is y (across
rolling).
The patch is read as one period of a periodic surface: its size is ``lx × ly = nx·dx × ny·dy``.

The processing steps return new objects and append to ``provenance``. A measured map goes
``detrended`` → ``periodised`` → ``resampled`` (→ ``scaled_to_rq``). When the map is larger than
the simulation window, ``resampled`` cuts the window out first; then periodise the result
(``resampled(...).periodised(...)``) because the cut-out is not periodic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal.windows import tukey

from micropit_hpc.errors import MicropitError
from micropit_hpc.spectral import Grid, rfft_plan

__all__ = ["DETREND_KINDS", "PERIODISE_METHODS", "Topography", "TopographyError"]

DETREND_KINDS = ("none", "mean", "plane", "quadratic")
PERIODISE_METHODS = ("none", "tukey", "mirror")
_REL = 1e-9  # relative slack when comparing lengths that went through a division


class TopographyError(MicropitError):
    """A surface map that cannot be used: one line naming the source, the value and the rule."""


def _positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TopographyError(f"{name} = {value!r}: not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise TopographyError(f"{name} = {v!r} m: must be positive and finite")
    return v


@dataclass(frozen=True, eq=False)
class Topography:
    """Heights [m] on a uniform periodic grid of spacing ``dx × dy`` [m], with their provenance.

    The heights are copied to a read-only float64 array. Raises :class:`TopographyError` for a
    map that is not 2-D, has fewer than 2 points along an axis, or holds non-finite values, and
    for a spacing that is not positive and finite.
    """

    heights: np.ndarray
    dx: float
    dy: float
    provenance: str = ""
    origin: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        try:
            h = np.array(self.heights, dtype=np.float64)
        except (TypeError, ValueError):
            raise TopographyError(
                f"heights of type {type(self.heights).__name__}: not numeric") from None
        if h.ndim != 2:
            raise TopographyError(f"heights of shape {h.shape}: must be a 2-D map (nx, ny)")
        if min(h.shape) < 2:
            raise TopographyError(f"heights of shape {h.shape}: need at least 2 points along "
                                  "x (axis 0) and y (axis 1)")
        bad = int(np.count_nonzero(~np.isfinite(h)))
        if bad:
            raise TopographyError(f"heights hold {bad} non-finite values (NaN or inf) of "
                                  f"{h.size}; fill them first (readers: nan_policy)")
        h.flags.writeable = False
        origin = tuple(float(v) for v in self.origin)
        if len(origin) != 2 or not all(math.isfinite(v) for v in origin):
            raise TopographyError(f"origin = {self.origin!r}: must be two finite numbers [m]")
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "dx", _positive("dx", self.dx))
        object.__setattr__(self, "dy", _positive("dy", self.dy))
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "provenance", str(self.provenance))

    # ---- geometry and statistics -------------------------------------------------------------
    @property
    def nx(self) -> int:
        return self.heights.shape[0]

    @property
    def ny(self) -> int:
        return self.heights.shape[1]

    @property
    def lx(self) -> float:
        """Period along x [m] = nx·dx."""
        return self.nx * self.dx

    @property
    def ly(self) -> float:
        """Period along y [m] = ny·dy."""
        return self.ny * self.dy

    @property
    def grid(self) -> Grid:
        return Grid(self.nx, self.ny, self.lx, self.ly)

    @property
    def mean(self) -> float:
        return float(self.heights.mean())

    @property
    def ra(self) -> float:
        """Arithmetic mean deviation R_a = mean |h − h̄| (ISO 4287 / ISO 25178 S_a)."""
        return float(np.abs(self.heights - self.heights.mean()).mean())

    @property
    def rq(self) -> float:
        """R_q = √⟨(z − ⟨z⟩)²⟩ over the map [m] (ISO 25178 S_q), computed on heights scaled
        by their largest magnitude so that huge values do not overflow the squares."""
        h = self.heights
        s = float(np.abs(h).max())
        return float((h / s).std() * s) if s > 0 else 0.0

    def _with(self, heights: np.ndarray, step: str, **changes) -> Topography:
        prov = f"{self.provenance}; {step}" if self.provenance else step
        return Topography(heights, changes.get("dx", self.dx), changes.get("dy", self.dy),
                          prov, self.origin)

    # ---- processing --------------------------------------------------------------------------
    def detrended(self, kind: str = "plane") -> Topography:
        """Subtract the least-squares fit of the given kind.

        "none": nothing; "mean": the mean height; "plane": a + b·x + c·y (form and tilt of the
        instrument); "quadratic": the second-order polynomial in x and y (also removes the
        curvature of a measured gear flank or disc, leaving the roughness).
        """
        if kind not in DETREND_KINDS:
            raise TopographyError(f"detrend kind = {kind!r}: unknown "
                                  f"(allowed: {', '.join(DETREND_KINDS)})")
        h = self.heights
        if kind == "none":
            return self._with(h, "detrended none")
        if kind == "mean":
            return self._with(h - h.mean(), "detrended mean")
        # centred, scaled coordinates keep the normal equations well conditioned
        x, y = np.meshgrid((np.arange(self.nx) - (self.nx - 1) / 2) / self.nx,
                           (np.arange(self.ny) - (self.ny - 1) / 2) / self.ny, indexing="ij")
        terms = [np.ones_like(h), x, y]
        if kind == "quadratic":
            terms += [x * x, x * y, y * y]
        a = np.stack([t.ravel() for t in terms], axis=1)
        coef = np.linalg.lstsq(a, h.ravel(), rcond=None)[0]
        return self._with(h - (a @ coef).reshape(h.shape), f"detrended {kind}")

    def periodised(self, method: str = "tukey", fraction: float = 0.1,
                   keep_rq: bool = False) -> Topography:
        """Make the patch tile without a step at its edges.

        "tukey": z → z̄ + c·w(x)·w(y)·(z − z̄), w a periodic Tukey (tapered cosine) window whose
        taper covers ``fraction`` (0 < fraction ≤ 0.5) of the length at each edge: the heights
        fall to the mean at the edges. With c = 1 the centre is unchanged and R_q drops (by
        about 14 % for fraction 0.1 on a random map); ``keep_rq`` sets c = R_q/R_q(tapered) so
        that the tapered map keeps the R_q it had (what the measured map's R_q says about the
        surface), and the provenance gives c.
        "mirror": even reflection [z, z reversed] along x and along y, so the map doubles to
        2nx × 2ny (and lx, ly double) and is continuous across the tile edges; it keeps every
        height but adds mirror symmetry, i.e. correlations that the real surface lacks.
        "none": the map as it is (for a patch that is already periodic, e.g. synthetic).
        """
        if method not in PERIODISE_METHODS:
            raise TopographyError(f"periodisation method = {method!r}: unknown "
                                  f"(allowed: {', '.join(PERIODISE_METHODS)})")
        h = self.heights
        if method == "none":
            return self._with(h, "periodised none")
        if method == "mirror":
            h2 = np.concatenate([h, h[::-1]], axis=0)
            return self._with(np.concatenate([h2, h2[:, ::-1]], axis=1), "periodised mirror")
        if not (0 < fraction <= 0.5):
            raise TopographyError(f"Tukey taper fraction = {fraction!r}: must be in (0, 0.5]")
        wx = tukey(self.nx, 2 * fraction, sym=False)[:, None]
        wy = tukey(self.ny, 2 * fraction, sym=False)[None, :]
        m = h.mean()
        dev = wx * wy * (h - m)
        step = f"periodised tukey({fraction:g})"
        if keep_rq:
            before, after = self.rq, float(dev.std())
            c = before / after if after > 0 else 1.0
            dev *= c
            step += f", R_q kept at {before:.6g} m (deviations × {c:.4g})"
        return self._with(m + dev, step)

    def resampled(self, grid: Grid, antialias: bool = True) -> Topography:
        """The heights on the simulation ``grid`` (spacing grid.dx × grid.dy, size lx × ly).

        The window starts at the origin corner (index 0, 0) of the map; a map larger than the
        window is cut there, a map smaller than it in either direction is an error. Values come
        from bilinear interpolation, vectorised and separable, wrapping periodically past the
        last row/column (the map is one period). When the grid is coarser than the map,
        ``antialias`` first removes the wavenumbers above the grid's Nyquist wavenumber π/Δ
        (sharp spectral cut, periodic FFT of the map), which the grid cannot represent and
        would otherwise alias onto longer wavelengths. Resampling onto the map's own grid
        returns the heights unchanged.
        """
        if grid.lx > self.lx * (1 + _REL) or grid.ly > self.ly * (1 + _REL):
            raise TopographyError(
                f"the map of {self.nx} x {self.ny} points at {self.dx * 1e6:.4g} x "
                f"{self.dy * 1e6:.4g} µm covers {self.lx * 1e6:.4g} µm x {self.ly * 1e6:.4g} µm, "
                f"smaller than the simulation window {grid.lx * 1e6:.4g} µm x "
                f"{grid.ly * 1e6:.4g} µm it must cover: shorten window.length_x_um / "
                "window.length_y_um, or give a larger map (or its true spacing, spacing_um)")
        h = self.heights
        coarser_x, coarser_y = grid.dx > self.dx * (1 + _REL), grid.dy > self.dy * (1 + _REL)
        steps = "bilinear, periodic wrap"
        if antialias and (coarser_x or coarser_y):
            g = self.grid
            plan = rfft_plan(g.shape)
            spec = plan.forward(h)
            keep = ((np.abs(g.kx) <= np.pi / grid.dx * (1 + _REL))
                    & (np.abs(g.ky) <= np.pi / grid.dy * (1 + _REL)))
            h = plan.inverse(spec * keep)
            steps += ", antialiased"
        ix0, ix1, fx = _linear_weights(grid.nx, grid.dx / self.dx, self.nx)
        iy0, iy1, fy = _linear_weights(grid.ny, grid.dy / self.dy, self.ny)
        hx = (1 - fx)[:, None] * h[ix0] + fx[:, None] * h[ix1]
        out = (1 - fy)[None, :] * hx[:, iy0] + fy[None, :] * hx[:, iy1]
        return self._with(out, f"resampled to {grid.nx}x{grid.ny} over {grid.lx:.6g} m x "
                               f"{grid.ly:.6g} m ({steps})", dx=grid.dx, dy=grid.dy)

    def scaled_to_rq(self, rq: float) -> Topography:
        """Scale the deviations from the mean so that R_q = ``rq`` [m]: z → z̄ + (z − z̄)·rq/R_q."""
        rq = float(rq)
        if not (math.isfinite(rq) and rq >= 0):
            raise TopographyError(f"target rq = {rq!r} m: must be finite and >= 0")
        if self.rq == 0 and rq > 0:
            raise TopographyError(f"target rq = {rq!r} m: a flat map cannot be scaled to it")
        m = self.heights.mean()
        factor = rq / self.rq if self.rq > 0 else 0.0
        return self._with(m + (self.heights - m) * factor, f"scaled to rq={rq:.6g} m")

    # ---- spectral moments (docs/model.md §4.4) ------------------------------------------------
    def spectral_moments(self, min_wavelength: float = 0.0) -> tuple[float, float, float]:
        """(m0, m2, m4) of the x-profiles, averaged over y [m², 1, 1/m²]; wavelengths along x
        shorter than ``min_wavelength`` [m] left out.

        m_n = ⟨ Σ_{k_x ≠ 0} k_x^n |Ĥ_j(k_x)|² / n_x² ⟩_j for the 1-D DFT Ĥ_j of profile j
        (Nayak, ASME J. Lubr. Technol. 93 (1971) 398; Longuet-Higgins 1957): m0 is the profile
        variance, m2 the mean-square slope, m4 the mean-square curvature. Computed from the 2-D
        half spectrum (Parseval along y): m_n = Σ_{k_x ≠ 0, k_y} w(k_y) k_x^n |Ĥ|² / (n_x n_y)².
        The k_x = 0 column (the mean of each profile) is left out.
        """
        g = self.grid
        spec = rfft_plan(g.shape).forward(self.heights)
        power = (spec.real**2 + spec.imag**2) * g.rfft_weight / float(g.nx * g.ny) ** 2
        power[0, :] = 0.0
        kx2 = g.kx**2
        if min_wavelength > 0.0:
            power = np.where(kx2 > (2 * math.pi / min_wavelength) ** 2 * (1 + 1e-12), 0.0,
                             power)
        return float(power.sum()), float((kx2 * power).sum()), float((kx2**2 * power).sum())

    def peak_spacing_x(self, min_wavelength: float = 0.0) -> float:
        """Mean peak spacing of the x-profiles λ_c = 2π √(m2/m4) [m] (docs/model.md §4.4;
        Nayak 1971),
        from the wavelengths of at least ``min_wavelength`` [m] (:meth:`spectral_moments`).

        A pure cosine of wavelength λ gives λ. Profiles that are constant along x have no peaks:
        the result is infinite (no micro-cycles). "Constant" is judged against the FFT's
        round-off: m0 ≤ 1e-26 ⟨z²⟩, i.e. profile deviations below 1e-13 of the heights.
        """
        m0, m2, m4 = self.spectral_moments(min_wavelength)
        if m4 <= 0 or m0 <= 1e-26 * float(np.mean(self.heights**2)):
            return math.inf
        return 2 * math.pi * math.sqrt(m2 / m4)


def _linear_weights(n_out: int, step: float, n_in: int):
    """Indices (i0, i1) and weights f for linear interpolation at t_k = k·step (in input cells),
    periodic in n_in. Positions within 1e-9 of a sample snap to it, so a same-size resampling
    reproduces the input exactly."""
    t = np.arange(n_out) * step
    r = np.rint(t)
    t = np.where(np.abs(t - r) < _REL * max(1.0, n_in), r, t)
    i0 = np.floor(t).astype(np.intp)
    f = t - i0
    return i0 % n_in, (i0 + 1) % n_in, f
