"""One load cycle at one contact position: the travelling window and its time steps (MODEL §4).

A load cycle is one passage of the surfaces through the contact. The window (a periodic patch
of L_x × L_y, default 2 b_ref square) travels with ū from the inlet x_c = −b to the outlet
x_c = +b in m steps: t_j = (j + ½) t_f/m, t_f = 2b/ū, x_c(t_j) = −b + ū t_j, mean pressure
p̄_j = p_H(x_c(t_j)); surface i is shifted by (u_i − ū) t_j relative to the window (exact
Fourier shift of the smooth heights). This module builds the window and surfaces of a
position and solves one time step: contact (:mod:`micropit_hpc.lubrication`) and stresses
(:mod:`micropit_hpc.mechanics`) in each body's material frame, where the pressure and
traction arrive by linear interpolation (no ringing) and the macro Hertz field is the one at
the window centre, so that σ_zz(0) = −p and σ_xz(0) = −q hold exactly (docs/contact.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from micropit_hpc.conditions import ContactStudy
from micropit_hpc.errors import MicropitError, SceneError
from micropit_hpc.lubrication.dry import ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.lubrication.mixed import MixedLubrication, MixedParameters, restore_mean
from micropit_hpc.lubrication.rheology import calibrated_prefactor
from micropit_hpc.mechanics.halfspace import HalfSpaceStress
from micropit_hpc.mechanics.hertz_field import EllipticalContactField, line_contact_stress
from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.share import from_root
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.plan import Window, choose_level
from micropit_hpc.scene import Body, Scene
from micropit_hpc.spectral import Grid, fourier_shift, rfft_plan, to_material_frame
from micropit_hpc.surfaces import (
    Topography,
    TopographyError,
    gaussian_surface,
    read_topography,
    self_affine_surface,
)


def body_surface(scene: Scene, body: int, grid: Grid, patch: int = 0) -> Topography:
    """Topography of body 1 or 2 on the window grid (MODEL.md §3), from its [bodyN.surface].

    ``patch`` numbers the independent synthetic patches of a study (``study.patches``): patch 0
    draws the random streams (seed, body), patch p > 0 the streams (seed, body, p).
    """
    b: Body = scene.body1 if body == 1 else scene.body2
    spec = b.surface
    key = f"body{body}.surface"
    seed, spawn = scene.window.seed, (body,) if patch == 0 else (body, patch)
    try:
        if spec.kind == "smooth" or b.Rq == 0.0:
            return Topography(np.zeros(grid.shape), grid.dx, grid.dy, "smooth")
        if spec.kind == "gaussian":
            return gaussian_surface(grid, b.Rq, spec.corr_x, spec.corr_y, seed, spec.acf, spawn)
        if spec.kind == "self_affine":
            long_c = spec.long_cutoff if spec.long_cutoff is not None else max(grid.lx, grid.ly)
            short_c = spec.short_cutoff if spec.short_cutoff is not None else 4 * max(grid.dx,
                                                                                      grid.dy)
            return self_affine_surface(grid, b.Rq, spec.hurst, long_c, short_c, seed, spawn)
        topo = read_topography(spec.file, dataset=spec.dataset, spacing=spec.spacing,
                               height_unit=spec.height_unit, nan_policy=spec.nan_policy)
        mapped = topo.detrended(spec.detrend).periodised(spec.periodise, keep_rq=True)
        topo = mapped.resampled(grid)
    except TopographyError as e:
        raise SceneError(scene.source, f"{key}: {e}") from None
    if spec.rescale:
        return topo.scaled_to_rq(b.Rq)
    if abs(topo.rq - b.Rq) > 0.05 * b.Rq:
        raise SceneError(scene.source, f"the measured map has R_q = {topo.rq * 1e6:.4g} µm on "
                                       f"the window ({mapped.rq * 1e6:.4g} µm as read and "
                                       f"detrended; the window is cut from it and sampled at "
                                       f"{grid.dx * 1e6:.3g} µm), more than 5 % from the "
                                       f"body's R_q; set body{body}.Rq_um to it or "
                                       f"{key}.rescale = true",
                         key=f"body{body}.Rq_um",
                         value=scene.document.get(f"body{body}", {}).get("Rq_um", b.Rq * 1e6))
    return topo


@dataclass(frozen=True)
class StepFields:
    """Contact at one time step (SI, window frame). ``traction1``/``traction2`` are the
    friction tractions on each body along +x, q_i = μ p sign(u_j − u_i) (MODEL.md §1)."""

    position: int
    step: int
    t: float
    x_c: float
    p_mean: float
    level: str
    pressure: np.ndarray
    clearance: np.ndarray
    solid: np.ndarray
    friction: np.ndarray
    phi: float
    iterations: int
    traction1: np.ndarray
    traction2: np.ndarray

    @property
    def mu_mean(self) -> float:
        """Pressure-weighted mean friction coefficient μ̄ (the macro field's)."""
        return float((self.friction * self.pressure).sum() / self.pressure.sum())


class PositionCycle:
    """The window, surfaces and solvers of one position of a study (MODEL.md §4).

    ``comm``: the ranks of the work item's group (default: this rank alone). With several
    ranks the contact of a step is solved on the group root and broadcast (it is 2-D and
    small); the stresses are computed on each rank's x-slab (:attr:`slab`).
    """

    def __init__(self, study: ContactStudy, position: int,
                 surfaces: tuple[Topography, Topography] | None = None,
                 steps: int | None = None, comm=None, window: Window | None = None):
        scene = study.scene
        if not 1 <= position <= len(study.conditions):
            raise MicropitError(f"{scene.source}: position {position} does not exist (the "
                                f"scene has positions 1 to {len(study.conditions)})")
        self.study, self.scene, self.position = study, scene, position
        c = self.cond = study.conditions[position - 1]
        self.window = Window.of(study) if window is None else window
        self.b_ref = self.window.b_ref
        self.grid = g = self.window.grid
        if surfaces is None:
            surfaces = (body_surface(scene, 1, g), body_surface(scene, 2, g))
        self._fft = rfft_plan(g.shape)
        self.set_surfaces(surfaces)
        rough = any(s.rq > 0 for s in surfaces)
        self.level = choose_level(scene, c, rough)
        self.steps = scene.window.steps if steps is None else int(steps)
        self.t_f = 2.0 * c.b / c.u_mean
        lub = scene.lubrication
        self.p_lim = lub.p_lim_hardness * min(scene.body1.hardness, scene.body2.hardness)
        self.half_spaces = ElasticHalfSpaces(g, study.E_prime)
        self.mixed = None
        if self.level == "mixed":
            lubr = scene.lubricant
            prm = MixedParameters(
                eta0=lubr.eta0, alpha=lubr.alpha_pv, tau0=lubr.tau0, p_lim=self.p_lim,
                prefactor=lub.prefactor if lub.prefactor is not None else calibrated_prefactor(),
                fluid_share=lub.fluid_share, combine=lub.combine, tol=lub.tol,
                max_iter=lub.max_iter, film_tol=lub.film_tol)
            self.mixed = MixedLubrication(
                g, geometry="line" if c.geometry == "line" else "elliptical", load=c.load,
                R=c.R, b=c.b, u1=c.u1, u2=c.u2, h_mean=c.hc, E_prime=study.E_prime, params=prm)
        self.z = self.window.z
        self.slab = Slab(SerialComm() if comm is None else comm, g, self.z.size)
        self._micro: dict[int, HalfSpaceStress] = {}
        self._macro_ellipse: dict[int, EllipticalContactField] = {}

    def set_surfaces(self, surfaces: tuple[Topography, Topography],
                     pits: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """Use new surfaces (worn, pitted) from now on; the contact level stays as chosen.

        ``pits``: each body's pitted columns (material frame) that carry no load
        (``life.pit_contact = "unloaded"``): after each contact solve the pressure there is
        set to zero and the mean pressure restored on the rest (:meth:`solve_step`)."""
        self.surfaces = tuple(surfaces)
        self.rough_spectra = tuple(self._fft.forward(-s.heights) for s in self.surfaces)
        self.pits = None if pits is None or not any(m.any() for m in pits) else tuple(pits)

    # ---- kinematics --------------------------------------------------------------------------
    def time(self, step: int) -> float:
        """t_j = (j + ½) t_f/m, steps counted from 0."""
        if not 0 <= step < self.steps:
            raise MicropitError(f"step {step} does not exist (the cycle has steps 0 to "
                                f"{self.steps - 1}; window.steps = {self.steps})")
        return (step + 0.5) * self.t_f / self.steps

    def centre(self, t: float) -> float:
        """x_c(t) = −b + ū t."""
        return -self.cond.b + self.cond.u_mean * t

    def mean_pressure(self, x: float) -> float:
        """p_H(x) = p0 √(1 − x²/b²) along the rolling axis of the Hertz contact."""
        c = self.cond
        return c.p0 * math.sqrt(max(0.0, 1.0 - (x / c.b) ** 2))

    def slip(self, body: int, t: float) -> float:
        """Shift of surface ``body`` relative to the window, (u_i − ū) t."""
        u = self.cond.u1 if body == 1 else self.cond.u2
        return (u - self.cond.u_mean) * t

    # ---- one step ----------------------------------------------------------------------------
    def solve_step(self, step: int, p_init: np.ndarray | None = None,
                   warm: dict | None = None) -> StepFields:
        """Contact at time step ``step`` (MODEL.md §4.1); collective over the group: the
        root solves and every rank gets its fields. ``p_init``: a warm start (the previous
        step's pressure); ``warm``: a dict the caller keeps for this step from one load-cycle
        evaluation to the next, whose pressures (the last evaluation's at this step) take
        precedence as warm starts and are updated (:meth:`MixedLubrication.solve`)."""
        return from_root(self.slab.comm, lambda: self._solve_step(step, p_init, warm))

    def _solve_step(self, step: int, p_init: np.ndarray | None,
                    warm: dict | None = None) -> StepFields:
        g, c, lub = self.grid, self.cond, self.scene.lubrication
        t = self.time(step)
        x_c = self.centre(t)
        p_mean = self.mean_pressure(x_c)
        r_now = tuple(fourier_shift(r, g, self.slip(i + 1, t))
                      for i, r in enumerate(self.rough_spectra))
        phi, iters = 0.0, 0
        if self.level == "smooth" or p_mean == 0.0:
            pressure = np.full(g.shape, p_mean)
            clearance = np.full(g.shape, c.hc)
        elif self.level == "dry":
            gap0 = self._fft.inverse(r_now[0] + r_now[1])
            start = p_init if warm is None else warm.get("dry", p_init)
            sol = solve_dry_contact(gap0, self.half_spaces, p_mean, p_lim=self.p_lim,
                                    tol=lub.tol, max_iter=lub.max_iter, p_init=start)
            pressure, clearance, phi, iters = sol.pressure, sol.gap, 1.0, sol.iterations
            if warm is not None:
                warm["dry"] = pressure.astype(np.float32)
        else:
            sol = self.mixed.solve(r_now, self.rough_spectra, p_mean, t, p_init=p_init,
                                   warm=warm)
            pressure, clearance, phi, iters = sol.pressure, sol.clearance, sol.phi, sol.iterations
        if self.pits is not None and p_mean > 0.0:
            pressure, clearance = self._unload_pits(pressure, clearance, p_mean, t)
        solid = clearance <= lub.h_min if self.level != "smooth" else np.zeros(g.shape, bool)
        friction = np.where(solid, lub.mu_bl, lub.mu_ehl)
        q = friction * pressure
        s1 = math.copysign(1.0, c.u2 - c.u1) if c.u2 != c.u1 else 0.0
        return StepFields(position=self.position, step=step, t=t, x_c=x_c, p_mean=p_mean,
                          level=self.level, pressure=pressure, clearance=clearance,
                          solid=solid, friction=friction, phi=phi, iterations=iters,
                          traction1=s1 * q, traction2=-s1 * q)

    def pit_mask(self, t: float) -> np.ndarray:
        """The columns of the window over a pit of either body at time t (each body's pits
        moved with its surface, to the nearest cell)."""
        g = self.grid
        mask = np.zeros(g.shape, bool)
        for i, m in enumerate(self.pits, start=1):
            if m.any():
                mask |= np.roll(m, int(round(self.slip(i, t) / g.dx)), axis=0)
        return mask

    def _unload_pits(self, pressure, clearance, p_mean: float, t: float):
        """Pits carry no load (``life.pit_contact = "unloaded"``): zero pressure over them, the
        mean p̄ restored on the other columns, and no solid contact there. When the intact
        columns cannot carry p̄ below p_lim (the window is mostly pitted), they carry p_lim and
        the rest of the load is spread evenly over the pit floors, which are then the
        surface: the load balance holds whatever the pitted fraction."""
        mask = self.pit_mask(t)
        if not mask.any():
            return pressure, clearance
        free = ~mask
        n, n_free = pressure.size, int(free.sum())
        p = np.zeros_like(pressure)
        if n_free and p_mean * n / n_free < self.p_lim:
            p[free] = restore_mean(pressure[free], p_mean * n / n_free, self.p_lim)
            clearance = np.where(mask, np.maximum(clearance, self.cond.hc), clearance)
        else:
            p[free] = self.p_lim
            p[mask] = (p_mean * n - self.p_lim * n_free) / (n - n_free)
        return p, clearance

    # ---- stresses ----------------------------------------------------------------------------
    def material_tractions(self, fields: StepFields, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Pressure and friction traction of ``fields`` in the material frame of ``body``:
        F_i(X) = F(X + (u_i − ū) t) by periodic linear interpolation along x
        (:func:`~micropit_hpc.spectral.to_material_frame`; docs/contact.md, "The stress
        history"). The pressure stays in [0, p_lim] and keeps its mean p̄, the traction its
        mean μ̄ p̄."""
        s = self.slip(body, fields.t)
        q = fields.traction1 if body == 1 else fields.traction2
        dx = self.grid.dx
        return to_material_frame(fields.pressure, s, dx), to_material_frame(q, s, dx)

    def macro_stress(self, fields: StepFields, body: int) -> np.ndarray:
        """The macro Hertz field with the mean traction μ̄ p_H at the window centre x_c(t_j)
        (and y = 0), shape (6, N_z, 1, 1): the same at every point of the window
        (docs/contact.md, "The stress history"). The micro contact is solved about the uniform
        mean pressure p̄_j = p_H(x_c), so this is the field whose surface values,
        σ_zz(0) = −p̄_j and σ_xz(0) = −μ̄ p̄_j, complete the micro field's to the contact's own
        p and q."""
        c = self.cond
        q = fields.traction1 if body == 1 else fields.traction2
        p_sum = float(fields.pressure.sum())
        mu_signed = float(q.sum()) / p_sum if p_sum > 0 else 0.0
        z = self.z[:, None, None]
        if c.geometry == "line":
            nu = (self.scene.body1 if body == 1 else self.scene.body2).nu
            return line_contact_stress(fields.x_c, z, c.b, c.p0, mu_signed, nu)
        return self._ellipse(body).stress(fields.x_c, 0.0, z, mu_signed)

    def stresses(self, fields: StepFields, body: int) -> np.ndarray:
        """σ (Voigt xx, yy, zz, yz, xz, xy; shape (6, N_z, nx, ny), on a slab of several ranks
        only its rows: (6, N_z, len(slab.rows), ny)) in the material frame of ``body`` at the
        step of ``fields`` (docs/contact.md, "The stress history"): the micro field (Fourier
        kernels, App. A.1) of the pressure and traction moved into the material frame
        (:meth:`material_tractions`), less their means, plus the macro field at the window
        centre (:meth:`macro_stress`). At z = 0: σ_zz = −p and σ_xz = −q of the
        material-frame maps, to round-off."""
        g = self.grid
        b_body = self.scene.body1 if body == 1 else self.scene.body2
        slab = self.slab
        micro = self._micro.get(body)
        if micro is None:
            micro = self._micro[body] = HalfSpaceStress(g, self.z, b_body.nu, slab)
        p, q = self.material_tractions(fields, body)
        rows = slab.rows
        P_hat = slab.forward(-p[rows])
        T_hat = slab.forward(-q[rows])
        sigma = micro.stresses(P_hat, T_hat)
        sigma += self.macro_stress(fields, body)
        return sigma

    def _ellipse(self, body: int) -> EllipticalContactField:
        """The elliptical Hertz field of ``body`` (built once: it takes seconds)."""
        field = self._macro_ellipse.get(body)
        if field is None:
            c = self.cond
            nu = (self.scene.body1 if body == 1 else self.scene.body2).nu
            field = self._macro_ellipse[body] = EllipticalContactField(c.b, c.a, c.p0, nu)
        return field

    def macro_history(self, body: int, mu_signed: float, samples: int) -> np.ndarray:
        """The smooth load cycle of ``body`` (MODEL.md §4.4 "macro cycle"): the Hertz field with
        the mean traction μ̄ p_H at x from −3b to 3b (``samples`` points) followed by the
        unloaded state, at every depth layer. Shape (samples + 1, 6, N_z, 1, n_y') with
        n_y' = 1 for a line contact and n_y for an elliptical one (the window rows)."""
        c = self.cond
        b_body = self.scene.body1 if body == 1 else self.scene.body2
        xs = np.linspace(-3.0 * c.b, 3.0 * c.b, int(samples))
        if c.geometry == "line":
            sig = line_contact_stress(xs[:, None], self.z[None, :], c.b, c.p0, mu_signed,
                                      b_body.nu)[..., None, None]            # (6, n, Nz, 1, 1)
        else:
            sig = self._ellipse(body).stress(xs[:, None, None], self.grid.y[None, None, :],
                               self.z[None, :, None], mu_signed)[:, :, :, None, :]
        sig = np.moveaxis(sig, 0, 1)
        return np.concatenate([sig, np.zeros((1, *sig.shape[1:]))])
