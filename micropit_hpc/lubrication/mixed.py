"""The fast mixed-lubrication model of [M10]/[B11] at one time step (docs/model.md §4.1, `mixed`).

Per Fourier mode k of the rough clearance of each surface i (r_i = −ẑ_i, its share of the
undeformed gap h̄ − z1 − z2), with the window travelling at ū through the contact:

1. elastic response of both bodies û = 4p̂/(E'κ) (:class:`~.dry.ElasticHalfSpaces`);
2. lubricated part, linearised Reynolds with Eyring viscosities η_x, η_y (:mod:`.rheology`):
   the particular solution h_a/r = (1 − iCQ)/(1 − iQ − iCQ), which moves with the surface, and
   the complementary wave made at the inlet, which is convected at ū and decays with the
   wavenumber ψ of the dispersion relation; its amplitude makes the in-contact clearance
   amplitude h_t = r/(1 + c1∇_nn + c2∇_nn²) (the [V00] amplitude reduction with the sliding
   correction ∇_nn);
3. dry part: elastic–perfectly-plastic contact of that lubricated clearance carrying φp̄;
4. pressure from the total displacement through the inverse frequency response, clipped to
   [0, p_lim], mean restored to p̄;
5. φ from the flow balance: mean deformed clearance = c_ρ(φp̄) h̄.

Choices we made where the published model is silent (each a documented parameter):

* **In the window frame** the particular part of surface i is its current (shifted) pattern,
  the complementary part is the pattern it had when the window entered the contact
  (x_c = −b, t = 0), multiplied by e^{i(ψ − k_x u_i/ū) ū t}: the wave travels with the window
  while the surface slides by (u_i − ū)t under it. The decay rate is taken at the current step's
  p̄ (frozen coefficient). At pure rolling both parts coincide and the clearance amplitude is
  h_t throughout.
* **Fluid share** (``fluid_share = "scaled"``): the fluid's deformation of the roughness is
  scaled by the fraction of the load the fluid carries, 1 − φ: H_lub = r + (1 − φ)(H_t − r).
  The [V00] reduction is a full-film result (φ = 0); without the scaling a vanishing film would
  not tend to the dry solution. ``"full"`` keeps the unscaled deformation.
* **Combination** (``combine = "contact"``): the dry contact acts on the lubricated clearance,
  so the final clearance is the dry solution's gap and the pressure is fluid + contact.
  ``"max_amplitude"`` is the literal rule of docs/model.md step 4 (keep, per mode, the larger
  clearance amplitude of the dry and the lubricated solutions); it undoes the flattening of
  the contact spots and is offered for comparison only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from micropit_hpc.compiled import resolve
from micropit_hpc.errors import MicropitError
from micropit_hpc.lubrication import rheology
from micropit_hpc.lubrication.dry import (
    ContactError,
    ElasticHalfSpaces,
    coarse_levels,
    restrict,
    solve_dry_contact,
)
from micropit_hpc.parallel.slab import Reductions
from micropit_hpc.spectral import Grid, rfft_plan

if TYPE_CHECKING:
    from micropit_hpc.scene import Lubricant, LubricationSpec

CALIBRATED_PREFACTOR = rheology.calibrated_prefactor()

#: The implementation :func:`solve_dispersion` uses when none is given
#: (:data:`~micropit_hpc.compiled.KERNELS`).
DISPERSION_KERNEL = "auto"
#: The compiled dispersion relation ends a mode's Newton loop in a stage once its step is at
#: most this fraction of |ψ|: with quadratic convergence the error left is of the order of its
#: square, below round-off.
DISPERSION_STEP_TOL = 1e-10
#: ... and in the stages before the last once its step is at most this fraction: an earlier
#: stage's root is only where the next stage's Newton steps start.
DISPERSION_STAGE_TOL = 1e-4


@dataclass(frozen=True)
class MixedSolution:
    """Pressure [Pa], clearance [m] and the load fraction φ carried by solid contact."""

    pressure: np.ndarray
    clearance: np.ndarray
    phi: float
    iterations: int
    film_mean: float
    #: [m] The clearance at or below which a point touches to the accuracy of the final dry
    #: solve (its :attr:`~micropit_hpc.lubrication.dry.DryContact.gap_accuracy`; 0 without one)
    touch: float = 0.0


def solve_dispersion(a, c, e, ky, eta_x, eta_y, steps: int = 8, newton: int = 8,
                     kernel: str | None = None):
    """Wavenumber ψ of the complementary wave, per mode (docs/model.md §4.1 step 2):

        ψ = k_x u_i/ū + i E' h̄³ Ω (ψ²/η_x + k_y²/η_y) / (48 ū (1 + E' h̄ Ω/(4B))),
        Ω² = ψ² + k_y²  (η_x multiplies ψ²; two published versions have a typo),

    written as ψ = a + i c Ω (ψ²/η_x + k_y²/η_y)/(1 + eΩ) with a = k_x u_i/ū,
    c = E'h̄³/(48ū), e = E'h̄/(4B). Solved by Newton's method with continuation in c from the
    inviscid root ψ = a (``steps`` stages), which follows the physical branch (Im ψ ≥ 0: the
    wave decays away from the inlet) even where the viscous term dominates. Returns (ψ, the
    largest relative residual).

    ``kernel`` (None: :data:`DISPERSION_KERNEL`): "numpy", the reference, runs every mode
    through all ``newton`` steps of every stage; "numba" (:mod:`._mixed_numba`) takes a mode
    out of the last stage once its Newton step is below :data:`DISPERSION_STEP_TOL` of |ψ|,
    out of an earlier one below :data:`DISPERSION_STAGE_TOL` (the same root to round-off, in
    a fraction of the time: docs/performance.md §11); "auto" is the compiled one where Numba
    can be imported.
    """
    a = np.asarray(a, dtype=complex)
    ky2 = np.asarray(ky, dtype=float) ** 2
    stages = np.geomspace(1.0 / 2 ** (steps - 1), 1.0, steps)
    mod = resolve(DISPERSION_KERNEL if kernel is None else kernel, "lubrication._mixed_numba",
                  "solve_dispersion")
    if mod is not None:
        a_c = np.ascontiguousarray(a).reshape(-1)
        ky2_c = np.ascontiguousarray(np.broadcast_to(ky2, a.shape), dtype=float).reshape(-1)
        psi = np.empty_like(a_c)
        worst, _ = mod.dispersion(a_c, ky2_c, float(c), float(e), float(eta_x), float(eta_y),
                                  stages, int(newton), DISPERSION_STEP_TOL,
                                  DISPERSION_STAGE_TOL, psi)
        return psi.reshape(a.shape), float(worst)
    psi = a.copy()
    for s in stages:
        cs = c * s
        for _ in range(newton):
            omega = np.sqrt(psi * psi + ky2)
            omega = np.where(omega == 0, 1e-300, omega)
            flux = psi * psi / eta_x + ky2 / eta_y
            den = 1.0 + e * omega
            F = psi - a - 1j * cs * omega * flux / den
            d_omega = psi / omega
            dF = 1.0 - 1j * cs * ((d_omega * flux + omega * 2 * psi / eta_x) * den
                                  - omega * flux * e * d_omega) / den**2
            psi = psi - F / dF
    omega = np.sqrt(psi * psi + ky2)
    F = psi - a - 1j * c * omega * (psi * psi / eta_x + ky2 / eta_y) / (1.0 + e * omega)
    scale = np.maximum(np.abs(psi), np.abs(a)) + 1e-300
    return psi, float(np.max(np.abs(F) / scale))


def solve_dispersion_rows(a, c, e, ky, eta_x, eta_y, kernel: str | None = None):
    """:func:`solve_dispersion` on a half spectrum (rows k_x in FFT order, the same k_y in
    every row) solved on the rows k_x ≥ 0 only: the relation is odd in the real direction,
    ψ(−a, k_y) = −conj ψ(a, k_y) (Ω, the flux and 1 + eΩ are conjugated, the i in front
    flips the sign of the viscous term), and the Newton iterates from ψ = a keep that
    symmetry exactly in floating point (negation and conjugation are exact, and so are the
    complex square root, product and quotient under them), so the mirrored rows are the ones
    a solve of the whole spectrum gives, bit for bit (tests/test_mixed.py), in half the time.
    Falls back to the whole spectrum where ``a`` is not antisymmetric in the rows."""
    a = np.asarray(a)
    nx = a.shape[0]
    m = nx // 2 + 1          # rows 0 … nx//2: k_x ≥ 0 (and the unpaired Nyquist row, nx even)
    partners = slice(nx - m, 0, -1)         # rows nx − j of the mirrored rows j = m … nx − 1
    ky = np.broadcast_to(ky, a.shape)
    if (a.ndim != 2 or nx < 3 or not np.array_equal(a[m:], -a[partners])
            or not np.array_equal(ky[m:], ky[partners])):
        return solve_dispersion(a, c, e, ky, eta_x, eta_y, kernel=kernel)
    half, res = solve_dispersion(a[:m], c, e, ky[:m], eta_x, eta_y, kernel=kernel)
    psi = np.empty(a.shape, dtype=complex)
    psi[:m] = half
    psi[m:] = -np.conj(half[partners])
    return psi, res


class MixedLubrication:
    """The mixed model on one window for one contact (docs/model.md §4.1).

    ``geometry``, ``load``, ``R``, ``b`` describe the macro contact (line: load per unit
    length; elliptical: total load, R = R_x, b the semi-axis along rolling); ``h_mean`` is the
    smooth central film h̄; ``u1``, ``u2`` the surface speeds. The settings are the scene's:
    ``lubrication`` (its tolerance, iteration limit, film tolerance, fluid share, combination
    and amplitude prefactor c_nn of ∇_nn, the calibrated one when not given,
    :func:`~.rheology.calibrated_prefactor`), the ``lubricant`` (η0, α, Eyring τ0) and the
    pressure cap ``p_lim`` = p_lim_hardness × the smaller hardness [Pa].

    ``slab``: the :class:`~micropit_hpc.parallel.slab.Slab` of a work item's group; with
    several ranks :meth:`solve` is collective and its dry solves are distributed over the
    slab's x rows (docs/hpc.md §2). The spectral steps (lubricated clearance, step 4) are
    2-D and cheap and are done on the whole window by every rank alike.
    """

    def __init__(self, grid: Grid, *, geometry: str, load: float, R: float, b: float,
                 u1: float, u2: float, h_mean: float, E_prime: float,
                 lubrication: LubricationSpec, lubricant: Lubricant, p_lim: float,
                 slab=None):
        self.grid, self.spec, self.lubricant = grid, lubrication, lubricant
        self.p_lim = float(p_lim)
        self.prefactor = (CALIBRATED_PREFACTOR if lubrication.prefactor is None
                          else lubrication.prefactor)
        self.E_prime, self.h_mean = float(E_prime), float(h_mean)
        self.u = (float(u1), float(u2))
        self.u_mean = 0.5 * (u1 + u2)
        self.hs = ElasticHalfSpaces(grid, E_prime, slab)
        self._fft = rfft_plan(grid.shape)
        M, L = rheology.moes_parameters(geometry, load, R, E_prime, lubricant.eta0, self.u_mean,
                                        lubricant.alpha_pv)
        self.moes = (M, L)
        # Venner–Lubrecht wavelength parameter of every mode, before the sliding correction
        kx, ky = np.abs(grid.kx), grid.ky
        with np.errstate(divide="ignore"):
            lam_x = np.where(kx > 0, 2 * np.pi / np.where(kx > 0, kx, 1), np.inf)
            lam_y = np.where(ky > 0, 2 * np.pi / np.where(ky > 0, ky, 1), np.inf)
        lam = np.minimum(lam_x, lam_y)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = lam_x / lam_y
            fbar = np.where(r > 1, np.exp(1 - 1 / np.where(r > 1, r, 1)), 1.0)
        if geometry == "line":
            nabla = lam / b * M**0.75 / L**0.5
        else:
            nabla = lam / b * math.sqrt(M / L)
        nabla = nabla * fbar
        nabla[0, 0] = 0.0
        self.nabla = nabla
        self._factors: dict[tuple[int, float, float], tuple] = {}
        self._steady: dict[int, tuple[float, tuple]] = {}     # body → (p̄, steady factors)
        self._factor_bytes = 0
        self._scan = None
        #: (φ, levels, f) of every film balance the last :meth:`solve` evaluated: levels 0 on
        #: the window, else on the window halved that many times (the coarse φ scan)
        self.last_scan: list[tuple[float, int, float]] = []

    # ---- step 2: lubricated clearance -------------------------------------------------------
    def lubricated_factors(self, body: int, p_mean: float, t: float):
        """(h_a/r, h_t/r, decay) of surface ``body`` (1 or 2) per mode at mean pressure p̄ and
        time t since the window entered: H_lub,i = (h_a/r) r_i(t) + (h_t/r − h_a/r) r_i(0) D."""
        h_a, h_t, rate = self.steady_factors(body, p_mean)
        return h_a, h_t, self.decay(rate, t)

    @staticmethod
    def decay(rate: np.ndarray, t: float) -> np.ndarray:
        """D = e^{i(ψ − k_x u_i/ū) ū t} per mode, |D| ≤ 1 (the growing part clipped), from
        ``rate`` = i(ψ − k_x u_i/ū) ū of :meth:`steady_factors`; D = 1 at the mean mode."""
        exponent = rate * t
        D = np.exp(np.minimum(exponent.real, 0.0) + 1j * exponent.imag)
        D[0, 0] = 1.0
        return D

    def steady_factors(self, body: int, p_mean: float):
        """(h_a/r, h_t/r, rate) of surface ``body`` at mean pressure p̄: the parts of
        :meth:`lubricated_factors` that do not depend on the time, the complementary wave's
        rate i(ψ − k_x u_i/ū) ū from the dispersion relation ψ (:func:`solve_dispersion_rows`)
        included."""
        g, oil = self.grid, self.lubricant
        ui, uj = self.u[body - 1], self.u[2 - body]
        ub, h, Ep = self.u_mean, self.h_mean, self.E_prime
        eta = rheology.barus_viscosity(oil.eta0, oil.alpha_pv, p_mean)
        eta_x, eta_y = rheology.eyring_viscosities(eta, oil.tau0, abs(ui - uj) / h)
        B = float(rheology.bulk_modulus(p_mean))
        kx, ky, kappa = g.kx, g.ky, g.kappa
        kap = np.where(kappa > 0, kappa, 1.0)
        flux = kx * kx / eta_x + ky * ky / eta_y
        flux = np.where(flux > 0, flux, 1.0)
        Q = 48 * (ui - ub) * kx / (Ep * h**3 * kap * flux)
        C = h * Ep * kap / (4 * B)
        h_a = (1 - 1j * C * Q) / (1 - 1j * Q - 1j * C * Q)
        # sliding-corrected amplitude reduction
        S_i = (ui - uj) / ub
        with np.errstate(invalid="ignore", divide="ignore"):
            K = 1 - np.tanh(0.25 * np.abs(Q) / np.where(self.nabla > 0, self.nabla, 1.0))
        base = max((1 + S_i) / 2, 0.0)
        nabla_nn = self.prefactor * self.nabla * base ** (0.1 + 0.5 * K)
        h_t = rheology.amplitude_ratio(nabla_nn)     # the [V00] fit the prefactor is calibrated on
        # complementary wave: decay e^{i(ψ − k_x u_i/ū) ū t}, |D| ≤ 1
        a = kx * ui / ub + 0 * ky
        psi, _ = solve_dispersion_rows(a, Ep * h**3 / (48 * ub), h * Ep / (4 * B),
                                       ky + 0 * kx, eta_x, eta_y)
        h_a[0, 0] = h_t[0, 0] = 1.0
        return h_a, h_t, 1j * (psi - a) * ub

    def cached_factors(self, body: int, p_mean: float, t: float):
        """(h_a/r, h_t/r − h_a/r, decay) of :meth:`lubricated_factors`, kept for the next call
        with the same (body, p̄, t): every load-cycle evaluation of a work item visits the
        same time steps, and the factors depend on neither the surfaces nor the pits. Kept up
        to :data:`FACTOR_CACHE_BYTES` in all; beyond it they are computed each time, but for
        the time-independent part of the last (body, p̄) of each body (:meth:`steady_factors`:
        the dispersion relation, most of the cost), which is always kept, for the mirror step
        of a load cycle that comes next (the same p̄, another t:
        :meth:`~micropit_hpc.cycle.PositionCycle.mirror_order`). The same numbers as
        :meth:`lubricated_factors` in every case."""
        key = (body, float(p_mean), float(t))
        hit = self._factors.get(key)
        if hit is not None:
            return hit
        last = self._steady.get(body)
        if last is not None and last[0] == float(p_mean):
            h_a, dh, rate = last[1]
        else:
            h_a, h_t, rate = self.steady_factors(body, p_mean)
            dh = h_t - h_a
            self._steady[body] = (float(p_mean), (h_a, dh, rate))
        hit = (h_a, dh, self.decay(rate, t))
        size = 3 * h_a.nbytes
        if self._factor_bytes + size <= FACTOR_CACHE_BYTES:
            self._factors[key] = hit
            self._factor_bytes += size
        return hit

    def lubricated_clearance(self, r_now, r_entry, p_mean: float, t: float) -> np.ndarray:
        """Half spectrum of the full-film clearance fluctuation Σ_i H_lub,i (mean mode 0)."""
        H = np.zeros(self.grid.spectral_shape, dtype=complex)
        for body in (1, 2):
            h_a, dh, D = self.cached_factors(body, p_mean, t)
            H += h_a * r_now[body - 1] + dh * r_entry[body - 1] * D
        H[0, 0] = 0.0
        return H

    # ---- steps 3–5 --------------------------------------------------------------------------
    def solve(self, r_now, r_entry, p_mean: float, t: float,
              p_init: np.ndarray | None = None, warm: dict | None = None,
              free: np.ndarray | None = None) -> MixedSolution:
        """Pressure and clearance at one step. ``r_now``/``r_entry``: half spectra of each
        surface's rough clearance −z_i at time t and at the window's entry (t = 0).

        ``p_init`` starts the first loaded solve of the coarse scan over :data:`PHI_SCAN`
        (default: uniform pressure); the scan's other solves start cold, with the
        coarse-to-fine start of :func:`~.dry.solve_dry_contact`, and not from the last trial
        load's pressure: at the paper gear's position 3 the cold solve takes
        0.7–0.8 s at 512² where the start from the previous trial's pressure took 1.3–2.1 s,
        and the whole step 22 s against 87 s at 1024²: docs/performance.md, "Contact
        iterations that do not grow with the grid"); each solve of the root search starts
        from the nearer end of its bracket. ``warm``: a dict the caller keeps for
        this time step from one load-cycle evaluation to the next (the surfaces are then at
        the same places, changed only by a sub-block's wear and pits): the solves at each
        trial load fraction of :data:`PHI_SCAN` start from the pressure they had in the last
        evaluation, the root search tries the last evaluation's root first (inside the
        bracket) and starts its solves from that root's pressure, and the dict is updated.

        The scan over :data:`PHI_SCAN` is made first on the window coarsened by up to
        2^:data:`SCAN_LEVELS` (:meth:`_coarse_scan`); only the trials that bracket the
        smallest root (and those the coarse grid does not clearly put above the film) are
        then solved on the window (:meth:`_verify_scan`), with the same bracket, root and
        pressures as a scan made on the window at every trial (tests/test_multilevel_contact.py).
        Where the root is φ = 1 (the paper gear's rough positions) that is one solve on the
        window instead of four. A window scanned on itself (too small to be coarsened, or its
        coarse scan failed) whose last evaluation at this step (``warm``) found no root
        starts at φ = 1 and skips the trials that solve proves above the film
        (:meth:`_certified_scan`, :data:`SCAN_CERTIFY`; not with open pits).

        ``free``: the columns of open micropits (``life.pit_contact = "open"``; whole window,
        None: none): the dry solves hold them at p = 0 (:func:`~.dry.solve_dry_contact`), so
        the solids' load goes to the other columns, and the flow balance averages the clearance
        over the other columns only (a pit is a closed pocket of oil, neither a passage for the
        flow nor a solid contact). Step 4's pressure over them is the caller's to remove.

        With a slab of several ranks (collective): ``r_now``, ``r_entry``, ``p_init`` and
        ``free`` are the whole window's on every rank, the pressures kept in ``warm`` this
        rank's rows (``self.hs.rows``), and the solution is the whole window's on every
        rank."""
        prm, fft, g = self.spec, self._fft, self.grid
        hs, rows = self.hs, self.hs.rows
        group = Reductions(hs.slab)
        N = g.nx * g.ny
        held = None if free is None or not free.any() else free[rows]
        n_flow = N if held is None else N - int(np.count_nonzero(free))
        r_tot = r_now[0] + r_now[1]
        r_tot = r_tot.copy()
        r_tot[0, 0] = 0.0
        H_t = self.lubricated_clearance(r_now, r_entry, p_mean, t)
        h_bar = self.h_mean
        start0 = None if p_init is None else p_init[rows]
        state = {"p": start0, "iters": 0}
        # the scan may start at φ = 1 (:meth:`_certified_scan`): its solve then writes a lower
        # bound on the exact balance below it into ``bound``
        certify = (SCAN_CERTIFY and held is None and warm is not None
                   and warm.get("no_root", False))
        bound = {}
        self.last_scan = []

        def clearance_spectrum(phi):
            if prm.fluid_share == "scaled":
                return r_tot + (1.0 - phi) * (H_t - r_tot)
            return H_t

        def balance(phi, sol):
            c_rho = float(rheology.density_correction(phi * p_mean))
            gap_open = np.maximum(sol.gap, 0.0)
            (open_sum,) = group.sums(gap_open.sum() if held is None
                                     else gap_open.sum(where=~held))
            return float(open_sum / n_flow) - c_rho * h_bar

        def film(phi, near=None):
            """Mean clearance minus the flow balance's c_ρ h̄, and the dry solution at φ, its
            solves started from ``near``'s pressure when given (else from ``p_init`` for the
            first loaded solve, or cold: coarse to fine). A trial of the scan below its last
            (``near`` None, 0 < φ < 1: its solution is never the answer, only the sign of its
            balance and a start) is solved to :data:`SCAN_TOLERANCE` in at most
            :data:`SCAN_MAX_ITERATIONS`, and again to the scene's tolerance when that fails or
            its balance is within :data:`SCAN_SIGN_MARGIN` of its error bound."""
            if near is None:        # the scan: p_init for its first loaded solve only
                start = start0 if state["p"] is start0 else None
            else:
                start = near.pressure if group.any(near.pressure) else state["p"]
            if warm is not None:
                start = warm.get(phi if phi in PHI_SCAN else "root", start)
            gap0 = fft.inverse(clearance_spectrum(phi))[rows]

            def dry(p_start, tol=prm.tol, max_iter=prm.max_iter):
                return solve_dry_contact(gap0, hs, phi * p_mean, p_lim=self.p_lim, tol=tol,
                                         max_iter=max_iter, p_init=p_start, free=held)

            loose = (near is None and 0.0 < phi < PHI_SCAN[-1]
                     and SCAN_TOLERANCE is not None and SCAN_TOLERANCE > prm.tol)
            if loose:
                try:
                    sol = dry(start, SCAN_TOLERANCE, min(prm.max_iter, SCAN_MAX_ITERATIONS))
                except ContactError:    # e.g. a yielded set that flips at the loose residual
                    loose = False
            if not loose:
                sol = dry(start)
            state["iters"] += sol.iterations
            f = balance(phi, sol)
            top = certify and phi == PHI_SCAN[-1]
            if loose or top:
                (total, squares) = group.sums(gap0.sum(), (gap0 * gap0).sum())
                rms = math.sqrt(max(squares / N - (total / N) ** 2, 0.0))
            if loose and abs(f) <= SCAN_SIGN_MARGIN * SCAN_TOLERANCE * rms:
                sol = dry(sol.pressure)
                state["iters"] += sol.iterations
                f = balance(phi, sol)
                loose = False
            if top:
                # the signed mean gap (≤ the open one where points yielded) less the film,
                # and less the solve's error on it: what :meth:`_certified_scan` builds on
                (signed,) = group.sums(sol.gap.sum())
                error = SCAN_SIGN_MARGIN * (SCAN_TOLERANCE if loose else prm.tol) * rms
                bound[phi] = (float(signed / N)
                              - float(rheology.density_correction(phi * p_mean)) * h_bar
                              - error)
            if group.any(sol.pressure):
                state["p"] = sol.pressure
                if warm is not None and phi in PHI_SCAN:
                    warm[phi] = sol.pressure.astype(np.float32)
            self.last_scan.append((phi, 0, f))
            return f, sol

        f0, _ = film(0.0)
        if f0 <= 0.0:  # full film: the fluid carries everything, surfaces apart
            H_lub = fft.inverse(H_t)
            clearance = H_lub - H_lub.mean() + h_bar
            if warm is not None:
                warm["no_root"] = False
            return self._finish(H_t, r_tot, clearance, 0.0, p_mean, state["iters"], h_bar)
        # The balance need not be monotone in φ (with fluid_share = "scaled" the dry part acts
        # on less flattened roughness as φ grows): take the smallest root, bracketed by a
        # coarse scan, and φ = 1 only when no φ lets the solids reach the film.
        # Each solve of the root search starts from the solution at the nearer end of the
        # bracket (its load and contact are the closest at hand).
        lo, flo, sol_lo = 0.0, f0, None
        hi, fhi, sol = None, None, None
        coarse = self._coarse_scan(clearance_spectrum, p_mean, state, free)
        if coarse is None and certify:
            # the last evaluation here found no root: φ = 1 first, and the trials below it
            # that it proves above the film are not solved
            spread = 0.0
            if prm.fluid_share == "scaled":
                d = fft.inverse(H_t - r_tot)
                # each rank's own transform: the group's largest, so that every rank decides
                # alike however its plan rounds
                spread = group.max(float(d.max() - d.mean()))
            lo, flo, sol_lo, hi, fhi, sol = self._certified_scan(film, f0, bound, spread)
        elif coarse is None:      # every trial on the window itself
            for trial in PHI_SCAN:
                f, s_trial = film(trial)
                if f <= 0.0:
                    hi, fhi, sol = trial, f, s_trial
                    break
                lo, flo, sol_lo = trial, f, s_trial
                sol = s_trial
        else:
            lo, flo, sol_lo, hi, fhi, sol = self._verify_scan(coarse, film, f0)
        sol_hi = sol
        if hi is None:
            phi = 1.0
        else:
            phi = hi
            guess = None if warm is None else warm.get("phi")
            side = 0        # +1: lo moved last, −1: hi moved last
            for _ in range(60):  # regula falsi (Illinois) on the bracketed film balance
                if guess is not None and lo < guess < hi:   # the last evaluation's root first
                    phi = guess
                else:
                    phi = hi - fhi * (hi - lo) / (fhi - flo)
                guess = None
                f, sol = film(phi, sol_lo if sol_lo is not None and phi - lo < hi - phi
                              else sol_hi)
                if abs(f) <= prm.film_tol * h_bar or hi - lo < 1e-9:
                    break
                # Illinois: the end kept twice running has its value halved (halving it
                # on every step, as before, made the search no faster than bisection)
                if f > 0:
                    lo, flo, sol_lo = phi, f, sol
                    if side > 0:
                        fhi *= 0.5
                    side = 1
                else:
                    hi, fhi, sol_hi = phi, f, sol
                    if side < 0:
                        flo *= 0.5
                    side = -1
        if warm is not None:
            warm["no_root"] = hi is None
            if hi is not None:
                warm["root"], warm["phi"] = sol.pressure.astype(np.float32), phi
        clearance = sol.gap if group.slab is None else group.slab.allgather_rows(sol.gap)
        H_final = fft.forward(clearance)
        if prm.combine == "max_amplitude":
            H_lub = clearance_spectrum(phi)
            keep = np.abs(H_lub) > np.abs(H_final)
            H_final = np.where(keep, H_lub, H_final)
            H_final[0, 0] = clearance.mean() * g.nx * g.ny
            clearance = fft.inverse(H_final)
        return self._finish(H_final, r_tot, clearance, phi, p_mean, state["iters"],
                            float(np.maximum(clearance, 0).mean()), sol.gap_accuracy)

    def _scan_grid(self):
        """(levels, coarse half-spaces) of the coarse φ scan (:data:`SCAN_LEVELS`,
        :data:`SCAN_POINTS`): the window halved ``levels`` times; (0, None) when the window is
        too small to be coarsened."""
        if self._scan is None:
            levels = min(SCAN_LEVELS, coarse_levels(self.grid, SCAN_POINTS)) if SCAN_LEVELS > 0 \
                else 0
            hs = None
            if levels:
                g = self.grid
                cg = Grid(g.nx >> levels, g.ny >> levels, g.lx, g.ly)
                hs = ElasticHalfSpaces(cg, self.E_prime)
            self._scan = (levels, hs)
        return self._scan

    def _coarse_scan(self, clearance_spectrum, p_mean: float, state: dict, free=None):
        """The film balance f(φ) of the trial fractions of :data:`PHI_SCAN` on the coarse grid
        (:meth:`_scan_grid`), in order up to the first f ≤ 0: a list of (φ, f). The coarse gap
        is the whole window's lubricated clearance restricted by full weighting
        (:func:`~.dry.restrict`), each solve cold (coarse to fine) at the scene's tolerance,
        serial on every rank alike (the decisions taken from it are the same on every rank of
        a slab). None when the window is not coarsened, or when a coarse solve fails (the
        same on every rank): every trial is then solved on the window. ``free``: the open
        pits' columns (:meth:`solve`), free on the coarse grid where at least half of a
        coarse cell is."""
        levels, hs = self._scan_grid()
        if not levels:
            return None
        prm, fft = self.spec, self._fft
        held = None
        if free is not None and free.any():
            held = free.astype(float)
            for _ in range(levels):
                held = restrict(held)
            held = held >= 0.5
        n_flow = hs.grid.nx * hs.grid.ny - (0 if held is None else int(held.sum()))
        if n_flow == 0:
            return None
        out = []
        for trial in PHI_SCAN:
            g = fft.inverse(clearance_spectrum(trial))
            for _ in range(levels):
                g = restrict(g)
            try:
                sol = solve_dry_contact(g, hs, trial * p_mean, p_lim=self.p_lim, tol=prm.tol,
                                        max_iter=prm.max_iter, free=held)
            except ContactError:    # the coarse grid is only a guide: scan on the window
                return None
            state["iters"] += sol.iterations
            c_rho = float(rheology.density_correction(trial * p_mean))
            gap_open = np.maximum(sol.gap, 0.0)
            open_sum = gap_open.sum() if held is None else gap_open.sum(where=~held)
            f = float(open_sum / n_flow) - c_rho * self.h_mean
            out.append((trial, f))
            self.last_scan.append((trial, levels, f))
            if f <= 0.0:
                break
        return out

    @staticmethod
    def _certified_scan(film, f0: float, bound: dict, spread: float):
        """The scan on the window from its top: φ = 1 solved first (``film`` writes its bound
        into ``bound``), then each lower trial of :data:`PHI_SCAN` in order unless that bound
        proves its balance positive, up to the first with f ≤ 0; the answer
        (:func:`_bracket_from`) is the plain scan's wherever the plain scan's signs are the
        exact balances' signs.

        The proof: the trial φ_k's undeformed gap is φ = 1's plus (1 − φ_k)·d, d the inverse
        transform of the lubricated clearance less the rough one (``fluid_share = "scaled"``;
        0 otherwise), and its load is lower. The contact is order-preserving: at a fixed
        load the approach δ of a gap g0 + e lies in [δ + min e, δ + max e] (measured, not
        proved for the discrete operator, whose stiffness has small positive off-diagonal
        entries; tests/test_multilevel_contact.py); and δ rises with the load (it is the
        multiplier of a convex problem's load constraint). So the signed mean gap ⟨g0⟩ − δ
        at φ_k is at least φ = 1's less (1 − φ_k)(max d − ⟨d⟩) (``spread``). The open mean
        gap is at least the signed one, and c_ρ rises with the pressure, so

            f(φ_k) ≥ ⟨g⟩₁ − c_ρ(p̄) h̄ − (1 − φ_k)·spread,

        ``bound[1]`` being the first two terms less the solve's error on them, never above
        f(1). So the trials skipped are the top ones, below any solved trial, and the lower
        end of a bracket is a solved trial (or φ = 0). Tests: tests/test_multilevel_contact.py
        (the two properties on random gaps, with and without the pressure cap; the trials a
        tabulated balance has solved; the same answers as the plain scan's)."""
        top = PHI_SCAN[-1]
        fine = {top: film(top)}
        for trial in PHI_SCAN[:-1]:
            if top in bound and bound[top] - (top - trial) * spread > 0.0:
                continue
            fine[trial] = film(trial)
            if fine[trial][0] <= 0.0:
                break
        roots = [t for t in PHI_SCAN if t in fine and fine[t][0] <= 0.0]
        return _bracket_from(PHI_SCAN.index(roots[0]) if roots else None, fine, film, f0)

    def _verify_scan(self, coarse, film, f0):
        """The scan's bracket from the coarse scan ``coarse`` ([(φ, f_coarse)]) with as few
        solves on the window as will reproduce the fine scan's answer: the first trial φ_k of
        :data:`PHI_SCAN` with f(φ_k) ≤ 0 on the window (the smallest root's bracket
        [φ_{k−1}, φ_k]), or none (φ = 1).

        The candidate, the coarse scan's first trial with f ≤ 0 (or the last trial), is solved
        on the window; the coarse balance's error there, d = |f − f_coarse|, sets the margin
        :data:`SCAN_MARGIN`·d: an earlier trial whose coarse f is within it is solved on the
        window too (its sign could differ there). A trial whose fine f contradicts the coarse
        sign is followed on the window as the plain scan would: a positive candidate moves
        the scan on to the later trials, a non-positive lower end moves the bracket down.
        Returns (lo, f(lo), solution at lo, hi, f(hi), solution at hi or, with no root, at
        φ = 1) as the plain scan's loop does, every f and solution of the window."""
        coarse_f = dict(coarse)
        k = PHI_SCAN.index(coarse[-1][0])
        f_k, s_k = film(PHI_SCAN[k])
        margin = SCAN_MARGIN * abs(f_k - coarse_f[PHI_SCAN[k]])
        fine = {PHI_SCAN[k]: (f_k, s_k)}
        # the trials below the candidate that the coarse grid does not clearly put above the
        # film: solved on the window, lowest first (the smallest root is wanted)
        for trial in PHI_SCAN[:k]:
            if coarse_f[trial] <= margin:
                fine[trial] = film(trial)
                if fine[trial][0] <= 0.0:
                    break
        roots = [t for t in PHI_SCAN if t in fine and fine[t][0] <= 0.0]
        if roots:
            j = PHI_SCAN.index(roots[0])
        else:       # the candidate is positive on the window: the plain scan goes on from it
            j = None
            for trial in PHI_SCAN[k + 1:]:
                fine[trial] = film(trial)
                if fine[trial][0] <= 0.0:
                    j = PHI_SCAN.index(trial)
                    break
        return _bracket_from(j, fine, film, f0)

    def _finish(self, H, r_tot, clearance, phi, p_mean, iters, film_mean,
                touch: float = 0.0) -> MixedSolution:
        """Step 4: pressure from the total displacement H − r through the inverse frequency
        response, clipped to [0, p_lim], mean restored to p̄."""
        dp = H - r_tot
        dp[0, 0] = 0.0
        p = self._fft.inverse(dp * self.hs.stiffness)
        p = restore_mean(p, p_mean, self.p_lim)
        return MixedSolution(p, clearance, float(phi), int(iters), float(film_mean),
                             float(touch))


#: Bytes of lubricated factors one model keeps (:meth:`MixedLubrication.cached_factors`): all
#: steps of a 256² window with 40 steps (two bodies) fit.
FACTOR_CACHE_BYTES = 256 * 2**20

#: Load fractions tried, in order, to bracket the smallest root of the flow balance.
PHI_SCAN = (0.25, 0.5, 0.75, 1.0)
#: Where the last evaluation at a step found no root (φ = 1), the scan on the window starts at
#: φ = 1 and solves only the lower trials that its bound does not prove above the film
#: (:meth:`MixedLubrication._certified_scan`; docs/performance.md §11, "Trials proved above
#: the film"). False: every trial, in order.
SCAN_CERTIFY = True

#: The tolerance of the dry solves of the scan's trials below its last (φ < 1) on the window
#: ([measured], docs/performance.md, "The φ scan's trials to a loose tolerance"): only the sign
#: of their balance f and their pressure as a start are used (the answer is the root search's
#: solve, or the trial φ = 1, both at the scene's tolerance). None: every solve at the
#: scene's tolerance.
SCAN_TOLERANCE: float | None = 1e-3
#: The most iterations of a loose trial's solve; one that does not converge in them (its
#: yielded set can flip for ever at the loose residual: measured, 5 to 23 of 5,000 trials in
#: 0.1 M cycles of the paper gear's position 5, each taking the whole
#: ``lubrication.max_iterations``) is solved at the scene's tolerance instead.
SCAN_MAX_ITERATIONS = 200
#: A loose trial whose |f| is within this many times SCAN_TOLERANCE × rms(gap) is solved again
#: at the scene's tolerance (its sign could be wrong): the balance of a solve stopped at
#: SCAN_TOLERANCE = 1e-3 differed from the converged one by at most 3.0 × 1e-3 × rms(gap) over
#: 5,640 trials of the paper gear (docs/performance.md §11), so 20 leaves a factor 6.7.
SCAN_SIGN_MARGIN = 20.0

#: The φ scan is first made on the window halved up to this many times (each coarse side
#: ≥ :data:`SCAN_POINTS`), and only the trials that bracket its root are solved on the window
#: (:meth:`MixedLubrication._verify_scan`); 0: every trial on the window.
SCAN_LEVELS = 3
#: The fewest points per side of the coarse φ scan's grid: a window that cannot be halved
#: once and keep them (128² and smaller with 128) scans on itself.
SCAN_POINTS = 128
#: A trial below the candidate bracket is solved on the window too when its coarse film
#: balance is within this many times the coarse balance's error at the candidate.
SCAN_MARGIN = 4.0


def _bracket_from(j: int | None, fine: dict, film, f0: float) -> tuple:
    """The scan's answer from the trials solved on the window, ``fine`` ({φ: (f, solution)}),
    whose smallest trial with f ≤ 0 is PHI_SCAN[j] (None: there is none, and φ = 1 is in
    ``fine``): (lo, f(lo), solution at lo, hi, f(hi), solution at hi or, with no root, at
    φ = 1), as the plain scan's loop returns them. The bracket's lower end is solved on the
    window where it was not (``film``); should it not be above the film after all, the
    bracket moves down to it (f0: the balance at φ = 0)."""
    if j is None:
        f1, s1 = fine[PHI_SCAN[-1]]
        return PHI_SCAN[-1], f1, s1, None, None, s1
    hi, (fhi, sol_hi) = PHI_SCAN[j], fine[PHI_SCAN[j]]
    while j > 0:
        lo = PHI_SCAN[j - 1]
        if lo not in fine:
            fine[lo] = film(lo)
        flo, sol_lo = fine[lo]
        if flo > 0.0:
            return lo, flo, sol_lo, hi, fhi, sol_hi
        j, hi, fhi, sol_hi = j - 1, lo, flo, sol_lo
    return 0.0, f0, None, hi, fhi, sol_hi


#: The implementation of :func:`restore_mean`'s clipped means
#: (:data:`~micropit_hpc.compiled.KERNELS`): "numba" adds each in one compiled pass
#: (``_mixed_numba.clipped_sum``), "numpy" with NumPy's pairwise sum; each answer is exact for
#: its own sum, and the two agree to round-off (tests/test_mixed.py).
MEAN_KERNEL = "auto"


def restore_mean(p: np.ndarray, p_mean: float, p_lim: float = math.inf,
                 kernel: str | None = None) -> np.ndarray:
    """clip(p + c, 0, p_lim) with the constant c chosen so the mean is p̄.

    The mean m(c) = ⟨clip(p + c, 0, p_lim)⟩ is continuous and non-decreasing in c, and so is
    its floating-point value (rounding is monotone). The answer is defined by bisection of
    [p̄ − max p, 2p̄ − min p] down to two adjacent floats lo < hi with m(lo) ≤ p̄ < m(hi),
    returning whichever of the two clipped fields has the mean nearer p̄. Because m is
    monotone, those two floats do not depend on the bracket the bisection starts from, so the
    bisection starts from a narrow bracket around the root of the piecewise-linear m found by
    safeguarded Newton steps (:func:`_mean_root`; slope: the share of points strictly
    between 0 and p_lim), widened until it brackets: the same floats as the full bisection
    (tests/test_mixed.py holds it to that bit for bit) in about a quarter of the passes.
    ``kernel`` (None: :data:`MEAN_KERNEL`): how m is added. "numpy": each pass a minimum and
    a maximum in a scratch array, their sum over n the same float as ``np.clip(...).mean()``;
    "numba": each pass (mean and slope) one compiled loop in another summation order, so its
    floats lo, hi are those of its own m, within round-off of NumPy's."""
    if p_mean >= p_lim:
        raise MicropitError(f"mean pressure {p_mean / 1e9:.4g} GPa ≥ p_lim "
                            f"{p_lim / 1e9:.4g} GPa: the window cannot carry it")
    compiled = resolve(MEAN_KERNEL if kernel is None else kernel, "lubrication._mixed_numba",
                       "restore_mean")
    buf, n = np.empty_like(p), p.size

    def clipped(c: float) -> np.ndarray:
        np.add(p, c, out=buf)
        np.minimum(buf, p_lim, out=buf)
        np.maximum(buf, 0.0, out=buf)
        return buf

    if compiled is None:
        def mean_at(c: float) -> float:
            return float(clipped(c).sum() / n)

        def slope() -> float:           # at the last mean_at
            return np.count_nonzero((buf > 0.0) & (buf < p_lim)) / n
    else:
        flat, inside = p.ravel(order="K"), [0]

        def mean_at(c: float) -> float:
            total, inside[0] = compiled.clipped_sum(flat, float(c), float(p_lim))
            return total / n

        def slope() -> float:
            return inside[0] / n

    lo, hi = p_mean - p.max(), 2 * p_mean - p.min()
    root = _mean_root(p, p_mean, lo, hi, mean_at, slope)
    if root is not None:
        lo, hi = _bracket(root, lo, hi, p_mean, mean_at)
    for _ in range(200):
        c = 0.5 * (lo + hi)
        if not lo < c < hi:
            break
        if mean_at(c) > p_mean:
            hi = c
        else:
            lo = c
    m_lo, m_hi = mean_at(lo), mean_at(hi)
    return clipped(lo if abs(m_lo - p_mean) <= abs(m_hi - p_mean) else hi)


#: Newton steps :func:`restore_mean` spends on its root before it bisects from the bracket.
MEAN_NEWTON_STEPS = 12


def _mean_root(p, p_mean, lo, hi, mean_at, slope) -> float | None:
    """Safeguarded Newton on m(c) − p̄ (:func:`restore_mean`) from c = p̄ − ⟨p⟩: a root to
    round-off, or None (non-finite values, or no convergence within
    :data:`MEAN_NEWTON_STEPS`). Each step stays inside the bracket it narrows, bisecting
    where a Newton step would leave it or the slope (``slope()``, at the last ``mean_at``)
    is zero."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return None
    c = min(max(p_mean - float(p.mean()), lo), hi)
    for _ in range(MEAN_NEWTON_STEPS):
        f = mean_at(c) - p_mean
        if f == 0.0:
            return c
        if f > 0:
            hi = c
        else:
            lo = c
        d = slope()
        step = c - f / d if d > 0 else 0.5 * (lo + hi)
        if not lo < step < hi:
            step = 0.5 * (lo + hi)
        if step == c or not lo < step < hi:
            return c
        if abs(step - c) <= 4 * math.ulp(max(abs(c), abs(step))):
            return step
        c = step
    return None


def _bracket(c: float, lo: float, hi: float, p_mean: float, mean_at) -> tuple[float, float]:
    """A bracket [a, b] ⊂ [lo, hi] around ``c`` with m(a) ≤ p̄ < m(b), each end at the
    original bracket's end where it cannot be nearer (:func:`restore_mean`): widened from
    a few ulps of the values by 16× at a time."""
    d = 16 * math.ulp(max(abs(c), abs(lo), abs(hi)))
    while True:
        a, b = max(c - d, lo), min(c + d, hi)
        if (a == lo or mean_at(a) <= p_mean) and (b == hi or mean_at(b) > p_mean):
            return a, b
        d *= 16.0
