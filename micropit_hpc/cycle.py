"""One load cycle at one contact position: the travelling window, its time steps and what the
cycle does to each body (docs/model.md §4).

A load cycle is one passage of the surfaces through the contact. The window (a periodic patch
of L_x × L_y, default 2 b_ref square) travels with ū from the inlet x_c = −b to the outlet
x_c = +b in m steps: t_j = (j + ½) t_f/m, t_f = 2b/ū, x_c(t_j) = −b + ū t_j, mean pressure
p̄_j = p_H(x_c(t_j)); surface i is shifted by (u_i − ū) t_j relative to the window (exact
Fourier shift of the smooth heights). This module builds the window and surfaces of a
position and solves one time step: contact (:mod:`micropit_hpc.lubrication`) and stresses
(:mod:`micropit_hpc.mechanics`) in each body's material frame, where the pressure and
traction arrive by linear interpolation (no ringing) and the macro Hertz field is the one at
the window centre, so that σ_zz(0) = −p̃ and σ_xz(0) = −q̃ hold exactly, p̃ and q̃ the maps
averaged over the process length (:meth:`PositionCycle.traction_spectra`; p and q at ℓ = 0;
docs/contact.md).

:meth:`PositionCycle.evaluate` runs the whole cycle on the surfaces it is given: the contact at
every step, the stresses and Dang Van per body, the damage per cycle (S–N line and cycle
counting) and the Archard wear per cycle (docs/model.md §4.1–§4.6). Its settings are the scene's
``[lubrication]``, ``[fatigue]`` and ``[wear]`` tables and the work item's k_lub; which surfaces
a cycle sees, and what its rates do over a block, is the life loop's (:mod:`micropit_hpc.life`,
docs/model.md §5).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from micropit_hpc.conditions import ContactConditions, ContactStudy
from micropit_hpc.errors import MicropitError
from micropit_hpc.fatigue.dangvan import ALPHA_DV, DangVanStream, dang_van
from micropit_hpc.fatigue.dangvan import CHUNK as DV_CHUNK
from micropit_hpc.fatigue.rainflow import rainflow_damage
from micropit_hpc.fatigue.sn import WoehlerLine
from micropit_hpc.lubrication.dry import ContactError, ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.lubrication.mixed import MixedLubrication, restore_mean
from micropit_hpc.mechanics.halfspace import (
    STRESS_CHUNK_BYTES,
    HalfSpaceStress,
    history_chunk_layers,
)
from micropit_hpc.mechanics.hertz_field import EllipticalContactField, line_contact_stress
from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.petsc import event
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.plan import Window, choose_level
from micropit_hpc.spectral import discrete_gaussian, fourier_shift, rfft_plan, to_material_frame
from micropit_hpc.surfaces import Topography
from micropit_hpc.surfaces.bodies import body_surface
from micropit_hpc.wear import WearRate, archard_wear, solid_weight

__all__ = ["STEP_SPACINGS", "BodyCycle", "CycleResult", "PositionCycle", "StepFields",
           "contact_parallel", "contact_split_min_cells", "counterface_spacing", "cycle_steps",
           "micro_cycles", "rainflow_steps", "slip_steps", "step_weights"]

#: Windows of at least this many cells split the contact solve of a group of several ranks
#: over its slabs (docs/hpc.md §2); smaller ones solve it on every rank of the group alike,
#: without communication (the one-rank numbers, bit for bit), because the collectives of
#: every CG iteration then cost more than the arithmetic they share (docs/performance.md,
#: "Distributed contact"). Overridden by ``MICROPIT_CONTACT_SPLIT_MIN_CELLS``.
CONTACT_SPLIT_MIN_CELLS = 128 * 128


def contact_split_min_cells() -> int:
    """:data:`CONTACT_SPLIT_MIN_CELLS`, or ``MICROPIT_CONTACT_SPLIT_MIN_CELLS`` when set (0:
    always split, e.g. to test the distributed solver on a small window)."""
    text = os.environ.get("MICROPIT_CONTACT_SPLIT_MIN_CELLS", "").strip()
    if not text:
        return CONTACT_SPLIT_MIN_CELLS
    try:
        return int(text)
    except ValueError:
        raise MicropitError(f"MICROPIT_CONTACT_SPLIT_MIN_CELLS={text!r}: give a whole number "
                            "of cells") from None


#: How a group of several ranks shares the contact of a load cycle (docs/hpc.md §2):
#: ``"steps"``, each rank solves whole windows, the time steps j ≡ rank (mod ranks), and the
#: step fields are then broadcast (no communication inside a solve; one rank's numbers bit for
#: bit); ``"slabs"``, every step is solved by the whole group over its x rows
#: (:func:`contact_split_min_cells`); ``"auto"``, steps for windows of at most
#: :data:`STEPS_MAX_CELLS` cells, slabs above. Overridden by ``MICROPIT_CONTACT_PARALLEL``.
CONTACT_PARALLEL = "auto"

#: The largest window whose contact ``"auto"`` solves whole on each rank (steps over the
#: group's ranks): a 1024² window's whole-window contact solvers and one load cycle's fields
#: fit in about 3 GB per rank (docs/scaling.md); larger windows split the solve over slabs,
#: which divides its memory by the ranks.
STEPS_MAX_CELLS = 1024 * 1024

_PARALLEL_MODES = ("auto", "steps", "slabs")


def contact_parallel(cells: int, mode: str | None = None) -> str:
    """``"steps"`` or ``"slabs"``: how a group shares a load cycle's contact on a window of
    ``cells`` cells (:data:`CONTACT_PARALLEL`). ``mode``: the setting, default
    ``MICROPIT_CONTACT_PARALLEL`` or :data:`CONTACT_PARALLEL`; ``"auto"`` is steps up to
    :data:`STEPS_MAX_CELLS` cells, slabs above."""
    source = "contact_parallel"
    if mode is None:
        mode = os.environ.get("MICROPIT_CONTACT_PARALLEL", "").strip()
        source = "MICROPIT_CONTACT_PARALLEL"
        mode = mode or CONTACT_PARALLEL
    if mode not in _PARALLEL_MODES:
        raise MicropitError(f"{source}={mode!r}: give one of {', '.join(_PARALLEL_MODES)}")
    if mode == "auto":
        return "steps" if cells <= STEPS_MAX_CELLS else "slabs"
    return mode


@dataclass(frozen=True)
class StepFields:
    """Contact at one time step (SI, window frame). ``traction1``/``traction2`` are the
    friction tractions on each body along +x, q_i = μ p sign(u_j − u_i) (docs/model.md §1).
    ``pit_load``: the share of the step's load that the contact solve put on pitted columns
    and that :meth:`PositionCycle._unload_pits` moved off them (0 without pits)."""

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
    pit_load: float = 0.0

    @property
    def mu_mean(self) -> float:
        """Pressure-weighted mean friction coefficient μ̄ (the macro field's)."""
        return float((self.friction * self.pressure).sum() / self.pressure.sum())


@dataclass(frozen=True)
class BodyCycle:
    """One load cycle's effect on one body: damage per cycle (N_z, n_x, n_y), wear per cycle
    (n_x, n_y) by regime, the rough and smooth Dang Van stresses [Pa], the micro-cycles per
    load cycle n_μ and the counterface's peak spacing λ_c [m]. ``damage_low``: the part of
    the damage per cycle from below the S–N line's data, N < n_min
    (:meth:`~micropit_hpc.fatigue.sn.WoehlerLine.low_damage`; None: not known, taken as 0)."""

    damage_rate: np.ndarray
    wear: WearRate
    tau_rough: np.ndarray
    tau_smooth: np.ndarray
    n_micro: float
    lam_c: float
    damage_low: np.ndarray | None = None


@dataclass(frozen=True)
class CycleResult:
    """A load-cycle evaluation: both bodies, the load fraction carried by solid contact φ
    (pressure-weighted over the steps), the solid-contact area fraction, the steps used and
    the wall time. ``plastic_share``: the share of the contact area (p > 0, all steps
    together) where the pressure is at the cap p_lim, i.e. where the material yields.
    ``pit_load``: the share of the load that the contact solves put on pitted columns and
    that the unloading moved to the other columns as a uniform (film) pressure
    (:attr:`StepFields.pit_load`, weighted like φ)."""

    bodies: tuple[BodyCycle, BodyCycle]
    phi: float
    solid_fraction: float
    steps: int
    wall_s: float
    plastic_share: float = 0.0
    pit_load: float = 0.0


def micro_cycles(cycle: PositionCycle, body: int, lam_c: float) -> float:
    """n_μ,i = 2b |u1 − u2| / (u_i λ_c,j) micro-cycles per load cycle (docs/model.md §4.4): the
    counterface j slides 2b|u1 − u2|/u_i past a point of body i while it crosses the contact."""
    c = cycle.cond
    u_i = c.u1 if body == 1 else c.u2
    if not math.isfinite(lam_c) or c.u1 == c.u2:
        return 0.0
    return 2.0 * c.b * abs(c.u1 - c.u2) / (u_i * lam_c)


#: Where the time steps fall in the transit (``window.step_spacing``, docs/model.md §4):
#: ``"cosine"``, x_c = −b cos θ_j with θ_j = (j + ½)π/m; ``"uniform"``, t_j = (j + ½) t_f/m.
STEP_SPACINGS = ("cosine", "uniform")

_HISTORY_BUFFER: list[np.ndarray] = []


def history_buffer(size: int) -> np.ndarray:
    """A float64 array of ``size`` elements for the stress history's chunks
    (:meth:`PositionCycle._streamed_dang_van`), one per process, reused by every load cycle and
    work item and grown to the largest asked for. A fresh array of tens of MB is a fresh
    ``mmap`` whose every page the kernel faults in at its first write, at every full
    evaluation of every body (docs/performance.md §2, "The history's buffer kept"); the items
    of a rank run one after another, so they can share it. It is the one chunk per rank that
    :mod:`micropit_hpc.estimate` counts. Its values are garbage:
    :meth:`PositionCycle.stress_history` writes every element before Dang Van reads it."""
    if not _HISTORY_BUFFER or _HISTORY_BUFFER[0].size < size:
        _HISTORY_BUFFER[:] = []             # the old one freed before the larger is made
        _HISTORY_BUFFER.append(np.empty(size))
    return _HISTORY_BUFFER[0][:size]


def step_weights(m: int, spacing: str = "uniform") -> np.ndarray:
    """Each step's share w_j of the transit time (Σ w_j = 1): the time cell it stands for.
    ``uniform``: 1/m; ``cosine``: the cell θ_j ± π/2m, w_j = sin θ_j sin(π/2m), which tile
    the transit exactly (Σ_j sin θ_j = 1/sin(π/2m))."""
    if spacing == "uniform":
        return np.full(m, 1.0 / m)
    theta = (np.arange(m) + 0.5) * math.pi / m
    return np.sin(theta) * math.sin(0.5 * math.pi / m)


def slip_steps(c: ContactConditions, length: float, spacing: str = "uniform") -> int:
    """The fewest steps m whose largest step lets the surfaces slip past each other by at most
    ``length`` [m] (docs/model.md §4): a step's slip is its time share w_j of the transit's
    2b|S| (:func:`step_weights`), so ``uniform`` needs 2b|S|/m ≤ length and ``cosine``, whose
    largest share is at most sin(π/2m) (exactly for odd m), m ≥ π / (2 asin(length/2b|S|)),
    less the one or two fewer steps whose largest share still fits. 1 without sliding."""
    slip = 2.0 * c.b * abs(c.S)
    if slip <= 0.0 or not length > 0.0 or math.isinf(length):
        return 1
    if spacing == "uniform":
        return max(1, math.ceil(slip / length - 1e-9))
    r = length / slip
    if r >= 1.0:
        return 1
    m = max(1, math.ceil(0.5 * math.pi / math.asin(r) - 1e-9))
    while m > 1 and step_weights(m - 1, spacing).max() <= r * (1 + 1e-12):
        m -= 1
    return m


def rainflow_steps(c: ContactConditions, steps: int, lam_c: float,
                   spacing: str = "uniform") -> int:
    """Time steps for rainflow counting at contact ``c`` (docs/model.md §4.4): the relative slip per
    step must not exceed λ_c/4 (uniform steps: 2b|S|/m ≤ λ_c/4, so m ≥ 8 b |S| / λ_c;
    :func:`slip_steps`); never fewer than ``steps``."""
    if not math.isfinite(lam_c) or lam_c <= 0:
        return steps
    return max(steps, slip_steps(c, lam_c / 4.0, spacing))


def counterface_spacing(scene, surfaces, dx: float) -> float:
    """The smaller peak spacing λ_c of the rough ``surfaces`` [m] (wavelengths below
    ``fatigue.peak_spacing_min_cells`` cells of ``dx`` left out; inf: both smooth)."""
    cut = scene.fatigue.peak_spacing_min_cells * dx
    return min(s.peak_spacing_x(cut) if s.rq > 0 else math.inf for s in surfaces)


def cycle_steps(scene, c: ContactConditions, lam_c: float) -> tuple[int, str]:
    """The time steps m of a load cycle at contact ``c`` whose surfaces have the peak spacing
    ``lam_c`` [m] (:func:`counterface_spacing`; inf: smooth), and why they exceed
    ``window.steps`` ("" when they do not; docs/model.md §4): the floor ``window.steps``,
    raised so that the largest step lets the surfaces slip past each other by at most
    λ_c/``window.steps_per_peak_spacing`` (:func:`slip_steps`), and for ``fatigue.counting =
    "rainflow"`` by at most λ_c/4 (:func:`rainflow_steps`); the strictest wins."""
    w = scene.window
    m, why = w.steps, ""
    if not math.isfinite(lam_c) or lam_c <= 0:
        return m, why
    per = w.steps_per_peak_spacing
    m_slip = slip_steps(c, lam_c / per, w.step_spacing)
    if m_slip > m:
        m, why = m_slip, (f"relative slip per step ≤ λ_c/{per:g}, λ_c = {lam_c * 1e6:.3g} µm; "
                          f"2b|S| = {2.0 * c.b * abs(c.S) / lam_c:.3g} λ_c over the transit")
    if scene.fatigue.counting == "rainflow":
        m_rf = rainflow_steps(c, m, lam_c, w.step_spacing)
        if m_rf > m:
            m, why = m_rf, (f"rainflow counting: slip per step ≤ λ_c/4, λ_c = "
                            f"{lam_c * 1e6:.3g} µm")
    return m, why


class PositionCycle:
    """The window, surfaces and solvers of one position of a study, and its load cycle
    (docs/model.md §4).

    ``comm``: the ranks of the work item's group (default: this rank alone). With several
    ranks the stresses are computed on each rank's x-slab (:attr:`slab`, a one-rank slab
    without ``comm``), and the contact is shared as ``parallel`` says
    (:func:`contact_parallel`, the resolved value in :attr:`contact_parallel`): ``"steps"``,
    :meth:`evaluate` gives each rank every ranks-th time step to solve on the whole window
    and then broadcasts the step fields; ``"slabs"``, each step (dry and mixed levels) is
    solved by the whole group on the x rows of :attr:`slab` (distributed FFTs, reductions
    in rank order; :meth:`solve_step`) and its 2-D maps then allgathered, or, on a window of
    fewer than :func:`contact_split_min_cells` cells, by every rank alike on the whole
    window. A :meth:`solve_step` called alone (not from :meth:`evaluate`) is solved by every
    rank alike under ``"steps"``.

    ``k_lub``: the work item's wear coefficient [s], one of ``wear.k_lub_s``. It is the cycle's
    like its position and surfaces: fixed for the item's life, and all that the cycle needs to
    know of the item besides. Default 0 (no Archard wear): the uses that never evaluate a
    whole cycle (``micropit snapshot``, a contact step) need none. The other settings of the
    cycle are the scene's: ``[lubrication]`` and the lubricant for the contact,
    ``[fatigue]`` (the S–N line :attr:`woehler`, α_DV, counting, macro samples, peak spacing
    cut) and ``wear.solid_factor`` for :meth:`evaluate`.
    """

    #: Bytes that one chunk of a body's stress history may take on this rank: :meth:`evaluate`
    #: streams the history through depth in chunks of :meth:`chunk_layers` layers (an instance
    #: may set its own; ``math.inf``: the whole depth in one chunk).
    stress_chunk_bytes: float = STRESS_CHUNK_BYTES

    def __init__(self, study: ContactStudy, position: int,
                 surfaces: tuple[Topography, Topography] | None = None,
                 steps: int | None = None, comm=None, window: Window | None = None,
                 k_lub: float = 0.0, parallel: str | None = None):
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
        if steps is None:     # the floor window.steps, raised by the kinematics (cycle_steps)
            steps = cycle_steps(scene, c, counterface_spacing(scene, surfaces, g.dx))[0]
        self.steps = int(steps)
        self.spacing = scene.window.step_spacing
        #: each step's share of the transit time, Σ = 1 (:func:`step_weights`)
        self.weights = step_weights(self.steps, self.spacing)
        self.t_f = 2.0 * c.b / c.u_mean
        lub = scene.lubrication
        self.p_lim = lub.p_lim_hardness * min(scene.body1.hardness, scene.body2.hardness)
        self.z = self.window.z
        self.slab = Slab(SerialComm() if comm is None else comm, g, self.z.size)
        # the contact solvers work on the slab's rows ("slabs"), or on the whole window
        # ("steps", or a window too small to gain from a split: contact_split_min_cells)
        self.contact_parallel = contact_parallel(g.nx * g.ny, parallel)
        split = (self.contact_parallel == "slabs" and self.slab.comm.size > 1
                 and g.nx * g.ny >= contact_split_min_cells())
        self.half_spaces = ElasticHalfSpaces(g, study.E_prime, self.slab if split else None)
        self.mixed = None
        if self.level == "mixed":
            self.mixed = MixedLubrication(
                g, geometry="line" if c.geometry == "line" else "elliptical", load=c.load,
                R=c.R, b=c.b, u1=c.u1, u2=c.u2, h_mean=c.hc, E_prime=study.E_prime,
                lubrication=lub, lubricant=scene.lubricant, p_lim=self.p_lim,
                slab=self.half_spaces.slab)
        fat = scene.fatigue
        self.woehler = WoehlerLine.from_spec(fat)
        self.alpha_dv = ALPHA_DV if fat.alpha is None else fat.alpha
        self.k_lub = float(k_lub)
        self._micro: dict[int, HalfSpaceStress] = {}
        self._whole: dict[int, HalfSpaceStress] = {}   # stress_by_steps
        self._macro_ellipse: dict[int, EllipticalContactField] = {}
        ell = scene.fatigue.process_length       # process_transfer, on the whole half spectrum
        self._process_gauss = discrete_gaussian(g, ell * ell / 12.0) if ell > 0.0 else None

    def set_surfaces(self, surfaces: tuple[Topography, Topography],
                     pits: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        """The surfaces the time steps see from now on (worn, pitted; :meth:`evaluate` sets
        those it is given); the contact level stays as chosen.

        ``pits``: each body's pitted columns (material frame) that carry no load
        (``life.pit_contact = "unloaded"``): after each contact solve the pressure there is
        set to zero and the mean pressure restored on the rest (:meth:`solve_step`)."""
        self.surfaces = tuple(surfaces)
        self.rough_spectra = tuple(self._fft.forward(-s.heights) for s in self.surfaces)
        self.pits = None if pits is None or not any(m.any() for m in pits) else tuple(pits)

    # ---- kinematics --------------------------------------------------------------------------
    def time(self, step: int) -> float:
        """t_j, steps counted from 0: ``uniform`` spacing (j + ½) t_f/m; ``cosine``
        ½ t_f (1 − cos θ_j), θ_j = (j + ½)π/m, so that x_c = −b cos θ_j."""
        if not 0 <= step < self.steps:
            raise MicropitError(f"step {step} does not exist (the cycle has steps 0 to "
                                f"{self.steps - 1}: m = {self.steps}, window.steps = "
                                f"{self.scene.window.steps} raised by the kinematics where "
                                "it is)")
        if self.spacing == "uniform":
            return (step + 0.5) * self.t_f / self.steps
        return 0.5 * self.t_f * (1.0 - math.cos((step + 0.5) * math.pi / self.steps))

    def centre(self, t: float) -> float:
        """x_c(t) = −b + ū t."""
        return -self.cond.b + self.cond.u_mean * t

    def mean_pressure(self, x: float) -> float:
        """p_H(x) = p0 √(1 − x²/b²) along the rolling axis of the Hertz contact."""
        c = self.cond
        return c.p0 * math.sqrt(max(0.0, 1.0 - (x / c.b) ** 2))

    def step_mean_pressure(self, step: int) -> float:
        """p̄_j = p_H(x_c(t_j)) of time step j, computed at the first of j and its mirror
        m − 1 − j: both spacings put the steps symmetrically about the contact's centre
        (x_c(t_{m−1−j}) = −x_c(t_j)) and p_H is even, so the two are one number exactly
        rather than to round-off (and the mirror reuses the step's lubricated factors,
        :meth:`MixedLubrication.cached_factors`)."""
        first = min(step, self.steps - 1 - step)
        return self.mean_pressure(self.centre(self.time(first)))

    def slip(self, body: int, t: float) -> float:
        """Shift of surface ``body`` relative to the window, (u_i − ū) t."""
        u = self.cond.u1 if body == 1 else self.cond.u2
        return (u - self.cond.u_mean) * t

    def rough_at(self, t: float) -> tuple:
        """Half spectra of each surface's rough clearance −z_i at time t, each slid by its
        :meth:`slip` (:func:`~micropit_hpc.spectral.fourier_shift`)."""
        return tuple(fourier_shift(r, self.grid, self.slip(i + 1, t))
                     for i, r in enumerate(self.rough_spectra))

    def rough_gap(self, step: int) -> np.ndarray:
        """The undeformed rough gap of both surfaces at time step ``step`` (whole window,
        its minimum at 0): the dry solve's gap at φ = 1 up to a constant, for benchmarks and
        tests that solve one step's contact by itself."""
        gap = self._fft.inverse(sum(self.rough_at(self.time(step))))
        return gap - gap.min()

    # ---- one step ----------------------------------------------------------------------------
    # the contact of one step at each level (:data:`~micropit_hpc.plan.LEVELS`): (rough
    # clearance spectra at t, p̄, t, warm start, warm dict) → (pressure, clearance, φ,
    # iterations, the clearance at or below which a point touches to the solve's accuracy)
    def _smooth_contact(self, r_now, p_mean: float, t: float, p_init, warm, free=None):
        """No roughness in the contact (or no load): p = p̄ and the central film everywhere."""
        g = self.grid
        return np.full(g.shape, p_mean), np.full(g.shape, self.cond.hc), 0.0, 0, 0.0

    def _dry_contact(self, r_now, p_mean: float, t: float, p_init, warm, free=None):
        """Elastic–perfectly-plastic contact of the roughness; the solids carry all (φ = 1)."""
        lub, hs = self.scene.lubrication, self.half_spaces
        rows = hs.rows            # the solver's rows (docs/hpc.md §2; not split: all)
        gap0 = self._fft.inverse(r_now[0] + r_now[1])[rows]
        start = None if p_init is None else p_init[rows]
        if warm is not None:
            start = warm.get("dry", start)
        sol = solve_dry_contact(gap0, self.half_spaces, p_mean, p_lim=self.p_lim,
                                tol=lub.tol, max_iter=lub.max_iter, p_init=start,
                                free=None if free is None else free[rows])
        if warm is not None:
            warm["dry"] = sol.pressure.astype(np.float32)     # this rank's rows
        if hs.distributed:
            return (hs.slab.allgather_rows(sol.pressure), hs.slab.allgather_rows(sol.gap), 1.0,
                    sol.iterations, sol.gap_accuracy)
        return sol.pressure, sol.gap, 1.0, sol.iterations, sol.gap_accuracy

    def _mixed_contact(self, r_now, p_mean: float, t: float, p_init, warm, free=None):
        """The fast mixed-lubrication model (:class:`MixedLubrication`)."""
        sol = self.mixed.solve(r_now, self.rough_spectra, p_mean, t, p_init=p_init, warm=warm,
                               free=free)
        return sol.pressure, sol.clearance, sol.phi, sol.iterations, sol.touch

    #: The contact solver of each level.
    _CONTACT: ClassVar[dict[str, Callable]] = {"smooth": _smooth_contact, "dry": _dry_contact,
                                               "mixed": _mixed_contact}

    def solve_step(self, step: int, p_init: np.ndarray | None = None,
                   warm: dict | None = None) -> StepFields:
        """Contact at time step ``step`` (docs/model.md §4.1); collective over the group: the
        dry and mixed solvers run on every rank of the group over its x rows (:attr:`slab`;
        distributed FFTs, sums in rank order, so every rank takes the same branches and
        raises the same errors) and the solution's pressure and clearance are allgathered;
        on a window of fewer than :func:`contact_split_min_cells` cells every rank solves
        the whole window itself instead, without communication (the one-rank numbers). The
        rest of the step (pits, friction, tractions) is done on the whole window by every
        rank alike: every rank gets the whole-window fields. ``p_init``: a warm start (the
        previous step's pressure, whole window); ``warm``: a dict the caller keeps for this
        step from one load-cycle evaluation to the next, whose pressures (the last
        evaluation's at this step; this rank's rows) take precedence as warm starts and are
        updated (:meth:`MixedLubrication.solve`)."""
        g, c, lub = self.grid, self.cond, self.scene.lubrication
        t = self.time(step)
        x_c = self.centre(t)
        p_mean = self.step_mean_pressure(step)
        r_now = self.rough_at(t)
        level = "smooth" if p_mean == 0.0 else self.level
        free = self._open_pits(t, p_mean) if level != "smooth" else None
        try:
            pressure, clearance, phi, iters, touch = self._CONTACT[level](
                self, r_now, p_mean, t, p_init, warm, free)
        except ContactError:
            if p_init is None and not warm:      # a cold start failed: that stands
                raise
            # a warm start from other surfaces (the last evaluation's, before the wear) can
            # stall the solver where p̄ is small, next to the contact's edges where the cosine
            # steps fall (a quick-scene step at 0.03 p0: residual 1e-3 after 5000 iterations,
            # converged from cold); once more from cold, the same on every rank of the group
            fresh = None if warm is None else {}
            pressure, clearance, phi, iters, touch = self._CONTACT[level](
                self, r_now, p_mean, t, None, fresh, free)
            if warm is not None:
                warm.clear()
                warm.update(fresh)
        pit_load = 0.0
        if self.pits is not None and p_mean > 0.0:
            pressure, clearance, pit_load = self._unload_pits(pressure, clearance, p_mean, t)
        # solid contact: clearance ≤ h_min, or 0 to the dry solve's accuracy (an elastic
        # contact point's gap is its residual, of round-off sign: DryContact.gap_accuracy)
        solid = (clearance <= max(lub.h_min, touch) if self.level != "smooth"
                 else np.zeros(g.shape, bool))
        friction = np.where(solid, lub.mu_bl, lub.mu_ehl)
        q = friction * pressure
        s1 = math.copysign(1.0, c.u2 - c.u1) if c.u2 != c.u1 else 0.0
        return StepFields(position=self.position, step=step, t=t, x_c=x_c, p_mean=p_mean,
                          level=self.level, pressure=pressure, clearance=clearance,
                          solid=solid, friction=friction, phi=phi, iterations=iters,
                          traction1=s1 * q, traction2=-s1 * q, pit_load=pit_load)

    def pit_mask(self, t: float) -> np.ndarray:
        """The columns of the window over a pit of either body at time t (each body's pits
        moved with its surface, to the nearest cell)."""
        g = self.grid
        mask = np.zeros(g.shape, bool)
        for i, m in enumerate(self.pits, start=1):
            if m.any():
                mask |= np.roll(m, int(round(self.slip(i, t) / g.dx)), axis=0)
        return mask

    def _open_pits(self, t: float, p_mean: float) -> np.ndarray | None:
        """The columns the contact solve holds at p = 0 at time t (``life.pit_contact =
        "open"``): those over a pit of either body (:meth:`pit_mask`), so that the
        counterface settles onto the intact columns around them; None where the pits are
        not open, there are none, or the intact columns could not carry p̄ below p_lim (the
        window mostly pitted: :meth:`_unload_pits` then spreads the rest over the pit
        floors)."""
        if self.pits is None or self.scene.life.pit_contact != "open":
            return None
        mask = self.pit_mask(t)
        n_free = mask.size - int(np.count_nonzero(mask))
        if not mask.any() or not n_free or p_mean * mask.size >= 0.999 * self.p_lim * n_free:
            return None
        return mask

    def _unload_pits(self, pressure, clearance, p_mean: float, t: float):
        """Pits carry no load (``life.pit_contact = "unloaded"``): zero pressure over them, the
        mean p̄ restored on the other columns, and no solid contact there. When the intact
        columns cannot carry p̄ below p_lim (the window is mostly pitted), they carry p_lim and
        the rest of the load is spread evenly over the pit floors, which are then the
        surface: the load balance holds whatever the pitted fraction.

        The solve saw the pitted columns at the height of the surface around them
        (:func:`~micropit_hpc.life.contact_surfaces`), so an asperity that pitted still held
        the counterface off its neighbours there; the load it took goes back to every other
        column as the same added pressure, a film's, which wears at k_lub and not at
        f_w k_lub. Returns the pressure, the clearance and that load's share of the step's
        (:attr:`StepFields.pit_load`; docs/life.md, "The model's range")."""
        mask = self.pit_mask(t)
        if not mask.any():
            return pressure, clearance, 0.0
        total = float(pressure.sum())
        moved = float(pressure[mask].sum()) / total if total > 0.0 else 0.0
        free = ~mask
        n, n_free = pressure.size, int(free.sum())
        p = np.zeros_like(pressure)
        if n_free and p_mean * n / n_free < self.p_lim:
            p[free] = restore_mean(pressure[free], p_mean * n / n_free, self.p_lim)
            clearance = np.where(mask, np.maximum(clearance, self.cond.hc), clearance)
        else:
            p[free] = self.p_lim
            p[mask] = (p_mean * n - self.p_lim * n_free) / (n - n_free)
        return p, clearance, moved

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
        centre (:meth:`macro_stress`). At z = 0: σ_zz = −p̃ and σ_xz = −q̃ of the
        material-frame maps averaged over the process length (p, q at ℓ = 0), to round-off.
        The whole depth at once; :meth:`evaluate` streams the layers instead
        (:meth:`stress_history`), with the same numbers."""
        sigma = self._micro_field(body).stresses(*self.traction_spectra(fields, body))
        sigma += self.macro_stress(fields, body)
        return sigma

    def _micro_field(self, body: int, whole: bool = False) -> HalfSpaceStress:
        """The micro field of ``body`` on this rank's slab, or with ``whole`` on the whole
        window on this rank alone (:attr:`stress_by_steps`); each built once per body."""
        cache = self._whole if whole else self._micro
        micro = cache.get(body)
        if micro is None:
            nu = (self.scene.body1 if body == 1 else self.scene.body2).nu
            slab = Slab(SerialComm(), self.grid, self.z.size) if whole else self.slab
            micro = cache[body] = HalfSpaceStress(self.grid, self.z, nu, slab)
        return micro

    @property
    def stress_by_steps(self) -> bool:
        """Whether :meth:`stress_history` shares the steps over the group's ranks: under
        ``contact_parallel = "steps"`` with several ranks, rank r makes the stress layers of
        the steps j ≡ r (mod ranks) on the whole window (one-rank transforms) and sends each
        rank its rows, instead of the group transforming every step over the slabs. The same
        numbers as one rank's, bit for bit (docs/hpc.md §2)."""
        return self.contact_parallel == "steps" and self.slab.comm.size > 1

    def process_transfer(self, cols: slice) -> np.ndarray | None:
        """The averaging over the material's process area (``fatigue.process_length_um`` = ℓ)
        as a transfer function on the half-spectrum columns ``cols``: a Gaussian of the
        second moment of an ℓ × ℓ square, σ² = ℓ²/12 along each axis, in its discrete form
        (:func:`~micropit_hpc.spectral.discrete_gaussian`: a positive kernel on any grid, so
        the averaged pressure stays non-negative; Ĝ → exp(−|k|² ℓ²/24) as the cell shrinks),
        Ĝ(0) = 1 (the load and the macro field unchanged). The stresses are linear in the tractions
        and the kernels commute with a convolution in the surface plane, so filtering the
        tractions' spectra filters every stress component at every depth alike. None for
        ℓ = 0, the paper's pointwise criterion (Morales-Espejel et al. 2018 §2: Dang Van at
        each grid point). The area average before a multiaxial criterion is the process
        volume of Fouvry et al. (J. Strain Anal. 37 (2002) 549) and the area method of the
        theory of critical distances (Taylor, The Theory of Critical Distances, 2007, ch. 2),
        both made for the steep gradients of contact fatigue (docs/life.md, "A process
        length for the criterion")."""
        return None if self._process_gauss is None else self._process_gauss[:, cols]

    def _stress_spectra(self, p: np.ndarray, q: np.ndarray, slab: Slab
                        ) -> tuple[np.ndarray, np.ndarray]:
        """Half spectra of σ_zz(0) = −p and σ_xz(0) = −q on ``slab``'s columns from the rows
        ``slab.rows`` of the material-frame maps, averaged over the process area
        (:meth:`process_transfer`) where ``fatigue.process_length_um`` > 0."""
        rows = slab.rows
        P, T = slab.forward(-p[rows]), slab.forward(-q[rows])
        g = self.process_transfer(slab.cols)
        if g is not None:
            P *= g
            T *= g
        return P, T

    def traction_spectra(self, fields: StepFields, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Half spectra (P̂, T̂x) of σ_zz(0) = −p and σ_xz(0) = −q_x in the material frame of
        ``body`` at the step of ``fields`` (:meth:`material_tractions`), this rank's columns
        ``slab.cols``, averaged over the process area where ``fatigue.process_length_um`` > 0
        (:meth:`process_transfer`: then σ_zz(0) = −p̃, the averaged pressure); fresh arrays.
        Collective (the forward FFTs)."""
        return self._stress_spectra(*self.material_tractions(fields, body), self.slab)

    def history_spectra(self, fields: list[StepFields], body: int) -> list:
        """The spectra that :meth:`stress_history` reads, one entry per step of ``fields``:
        every step's :meth:`traction_spectra` (collective), or under :attr:`stress_by_steps`
        the whole window's half spectra of this rank's steps (j ≡ rank mod ranks; this rank's
        transforms alone) and None for the others'."""
        if not self.stress_by_steps:
            return [self.traction_spectra(f, body) for f in fields]
        whole = self._micro_field(body, whole=True).slab
        comm = self.slab.comm
        out = []
        for j, f in enumerate(fields):
            if j % comm.size != comm.rank:
                out.append(None)
                continue
            out.append(self._stress_spectra(*self.material_tractions(f, body), whole))
        return out

    def chunk_layers(self, steps: int | None = None) -> int:
        """Depth layers per chunk of the streamed stress history (:meth:`evaluate`): as many as
        keep one chunk's history, steps × 6 × layers × the points of the group's largest slab
        float64, within :attr:`stress_chunk_bytes`, at least one
        (:func:`~micropit_hpc.mechanics.halfspace.history_chunk_layers`)."""
        m = self.steps if steps is None else int(steps)
        # the largest slab of the group: every rank takes the same chunks, so that the
        # collective inverse transforms of the layers run in the same order on all of them
        return history_chunk_layers(self.z.size, m, max(self.slab.counts) * self.grid.ny,
                                    self.stress_chunk_bytes)

    def stress_history(self, spectra, macro, body: int, layers: slice,
                       out: np.ndarray | None = None) -> np.ndarray:
        """The stress history of ``body`` on the depth layers ``layers`` (a slice of :attr:`z`),
        shape (m, 6, n_layers, rows of the slab, ny): at each step j the micro field of the
        kept spectra ``spectra[j]`` (:meth:`history_spectra`) on those layers plus the macro
        field ``macro[j]`` (:meth:`macro_stress`, all layers) on them. Over the slabs, the
        same numbers as :meth:`stresses` on those layers; under :attr:`stress_by_steps`, those
        of one rank's :meth:`stresses`, on this rank's rows. ``out``: an optional float64
        array of that shape. Collective (the inverse FFTs, or the steps' rows sent over)."""
        k = range(self.z.size)[layers]
        shape = (len(spectra), 6, len(k), self.slab.nx_local, self.grid.ny)
        hist = np.empty(shape) if out is None else out
        if hist.shape != shape:
            raise ValueError(f"out has shape {hist.shape}, expected {shape}")
        if len(macro) != len(spectra):
            raise ValueError(f"{len(spectra)} steps of spectra but {len(macro)} of macro field")
        micro = None if self.stress_by_steps else self._micro_field(body)
        if micro is not None and micro.serial:
            # one rank: each layer's micro field plus the macro field written in one pass
            # from the transform's output (the same sum as the copy and the += below)
            for j, (P_hat, T_hat) in enumerate(spectra):
                mac = macro[j][:, layers]
                for kk, sigma in micro.layer_fields(P_hat, T_hat, layers=layers):
                    np.add(sigma, mac[:, kk], out=hist[j, :, kk])
            return hist
        if micro is None:
            self._history_by_steps(spectra, body, layers, hist)
        else:
            for j, (P_hat, T_hat) in enumerate(spectra):
                micro.stresses(P_hat, T_hat, out=hist[j], layers=layers)
        for j, mac in enumerate(macro):
            hist[j] += mac[:, layers]
        return hist

    def _history_by_steps(self, spectra, body: int, layers: slice, hist: np.ndarray) -> None:
        """The micro part of :meth:`stress_history` under :attr:`stress_by_steps`, into
        ``hist``: in round i, rank r makes layer by layer the whole window's stresses of step
        i·R + r (:meth:`HalfSpaceStress.layer_fields`), keeps its own rows and sends every
        other rank its rows, component by component straight from the transform's output,
        while it receives theirs of steps i·R + q. Collective (point to point, one wait per
        layer and round)."""
        from mpi4py import MPI

        comm = self.slab.comm
        size, rank = comm.size, comm.rank
        micro = self._micro_field(body, whole=True)
        ends = np.cumsum(self.slab.counts)
        bounds = [(int(e - c), int(e)) for c, e in zip(self.slab.counts, ends, strict=True)]
        rows, n_layers, m = self.slab.rows, hist.shape[2], hist.shape[0]
        tag = 7300                      # + the component: per pair, in order within a wait
        for i in range(0, m, size):
            j = i + rank
            mine = (micro.layer_fields(*spectra[j], layers=layers) if j < m else None)
            for kk in range(n_layers):
                reqs = [comm.Irecv(hist[i + q, c, kk], source=q, tag=tag + c)
                        for q in range(size) if q != rank and i + q < m for c in range(6)]
                if mine is not None:
                    _, sigma = next(mine)
                    for q, (a, b) in enumerate(bounds):
                        if q != rank:
                            reqs.extend(comm.Isend(sigma[c, a:b], dest=q, tag=tag + c)
                                        for c in range(6))
                    hist[j, :, kk] = sigma[:, rows]
                MPI.Request.Waitall(reqs)

    def _ellipse(self, body: int) -> EllipticalContactField:
        """The elliptical Hertz field of ``body`` (built once: it takes seconds)."""
        field = self._macro_ellipse.get(body)
        if field is None:
            c = self.cond
            nu = (self.scene.body1 if body == 1 else self.scene.body2).nu
            field = self._macro_ellipse[body] = EllipticalContactField(c.b, c.a, c.p0, nu)
        return field

    def macro_history(self, body: int, mu_signed: float, samples: int) -> np.ndarray:
        """The smooth load cycle of ``body`` (docs/model.md §4.4 "macro cycle"): the Hertz field
        with the mean traction μ̄ p_H at x from −3b to 3b (``samples`` points) followed by the
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

    def _streamed_dang_van(self, fields: list[StepFields], body: int, rainflow: bool):
        """τ_DV (N_z, rows, ny) of ``body`` over the cycle of ``fields``, streamed through depth
        (docs/performance.md "Streamed stresses"): the spectra of every step's pressure and
        traction in the body's frame (forward FFTs) and the macro field are made once and kept
        (O(N² m)); then, chunk by chunk of :meth:`chunk_layers` layers, the chunk's history
        (:meth:`stress_history`, written into one reused buffer) goes through Dang Van.

        The chunks go through Dang Van as a :class:`~micropit_hpc.fatigue.dangvan.DangVanStream`
        (points in (z, x, y) order, the NumPy path in batches of ``DV_CHUNK``), whose results
        equal one call on the whole (m, 6, N_z, rows, ny) history bit for bit. With
        ``rainflow`` the series τ̂ + α σ_H of every point is kept (m × N_z × rows × ny) and
        counted at the end as before. Returns (τ_DV, rate, low); rate and low are None without
        ``rainflow``."""
        sn, nz = self.woehler, self.z.size
        with event("stresses"):
            spectra = self.history_spectra(fields, body)
            macro = [self.macro_stress(f, body) for f in fields]
        m, rows, ny = len(fields), self.slab.nx_local, self.grid.ny
        plane = rows * ny
        stream = DangVanStream(m, nz * plane, alpha=self.alpha_dv, batch=DV_CHUNK,
                               keep_series=rainflow)
        size = self.chunk_layers(m)
        buf = history_buffer(m * 6 * size * plane)
        for k0 in range(0, nz, size):
            k1 = min(nz, k0 + size)
            hist = buf[:m * 6 * (k1 - k0) * plane].reshape(m, 6, k1 - k0, rows, ny)
            with event("stresses"):
                self.stress_history(spectra, macro, body, slice(k0, k1), out=hist)
            with event("dang_van"):
                stream.feed(hist.reshape(m, 6, -1))     # points k0·plane … k1·plane
        with event("dang_van"):
            dv = stream.result()
        tau, series = dv.tau_dv, dv.series
        shape = self.slab.local_shape
        rate = low = None
        if rainflow:
            with event("damage_rate"):
                rate = rainflow_damage(series, sn.damage).reshape(shape)
                low = rainflow_damage(series, sn.low_damage).reshape(shape)
        return tau.reshape(shape), rate, low

    # ---- the load cycle ----------------------------------------------------------------------
    def mirror_order(self, step: int) -> tuple[int, int]:
        """The place of ``step`` in the order the contact solves the cycle's steps
        (:meth:`_contact_steps`): by pair k = min(j, m − 1 − j) (step j and its mirror
        m − 1 − j have the same p̄, :meth:`step_mean_pressure`, hence the same lubricated
        factors but for their decay, :meth:`MixedLubrication.cached_factors`), then by j."""
        return (min(step, self.steps - 1 - step), step)

    def step_owners(self, ranks: int) -> list[int]:
        """The rank of a group of ``ranks`` that solves each step under ``"steps"``: the pairs
        (j, m − 1 − j) round robin (rank k mod ranks, k = min(j, m − 1 − j)), so that a step
        and its mirror are solved on one rank, one after the other, where that gives no rank
        more than ⌈m/ranks⌉ steps (63 steps on 2 ranks, 20 on 2 or 5, 40 on 4); otherwise the
        steps round robin (j mod ranks: 20 steps on 4 ranks would be 6, 6, 4, 4 in pairs)."""
        m = self.steps
        pairs = [min(j, m - 1 - j) % ranks for j in range(m)]
        if max(pairs.count(r) for r in range(ranks)) <= -(-m // ranks):
            return pairs
        return [j % ranks for j in range(m)]

    def _contact_steps(self, warm: dict | None,
                       on_step: Callable[[int], None] | None) -> list[StepFields]:
        """The contact at every time step of the cycle (:meth:`evaluate`), as StepFields on
        every rank of the group. Each step starts from its ``warm`` dict (the last evaluation's
        solution at that step) or cold, never from the step before, so that a step's solution
        does not depend on which rank solved which steps, or in which order: ``"steps"`` on
        any number of ranks gives one rank's numbers bit for bit. The steps are solved in
        :meth:`mirror_order` (each step next to its mirror, whose lubricated factors it
        reuses). Under ``"steps"`` with several ranks, rank r solves its steps
        (:meth:`step_owners`) on the whole window, without communication, and the step fields
        are then broadcast from their solver in step order; the first error in that order of
        any rank is raised on every rank of the group, the one a single rank would raise."""
        comm = self.slab.comm
        share = self.contact_parallel == "steps" and comm.size > 1
        ranks = comm.size if share else 1
        owners = self.step_owners(ranks)
        order = sorted((j for j in range(self.steps) if owners[j] == comm.rank or not share),
                       key=self.mirror_order)
        mine, error = {}, None
        for done, j in enumerate(order, start=1):
            try:
                with event("contact"):
                    mine[j] = self.solve_step(
                        j, None, None if warm is None else warm.setdefault(j, {}))
            except MicropitError as e:
                if not share:
                    raise
                error = (self.mirror_order(j), e)
                break
            if on_step is not None:
                on_step(min(self.steps, done * ranks))
        if not share:
            return [mine[j] for j in range(self.steps)]
        failed = [e for e in comm.allgather(error) if e is not None]
        if failed:
            raise min(failed, key=lambda f: f[0])[1]
        return [comm.bcast(mine.get(j), root=owners[j]) for j in range(self.steps)]

    def wear_of(self, fields: list[StepFields], body: int) -> WearRate:
        """The Archard wear per load cycle of ``body`` in its material frame over the cycle of
        ``fields`` (:func:`~micropit_hpc.wear.archard_wear`, docs/model.md §4.6)."""
        c = self.cond
        own, other = ((self.scene.body1, self.scene.body2) if body == 1
                      else (self.scene.body2, self.scene.body1))
        with event("wear_rate"):
            h_min, ramp = self.scene.lubrication.h_min, self.scene.wear.solid_ramp * c.hc
            return archard_wear([f.pressure for f in fields],
                                [solid_weight(f.clearance, h_min, ramp)
                                 if self.level != "smooth" and ramp > 0 else f.solid
                                 for f in fields],
                                [self.slip(body, f.t) for f in fields], self.grid.dx, c.u_s,
                                own.hardness, other.hardness, self.k_lub,
                                self.scene.wear.f_w, self.half_spaces.self_compliance,
                                None if self.spacing == "uniform" else self.weights)

    def wear_rates(self, surfaces: tuple[Topography, Topography],
                   pits: tuple[np.ndarray, np.ndarray] | None = None,
                   warm: dict | None = None) -> tuple[WearRate, WearRate]:
        """A contact-only load cycle on ``surfaces``: the contact at every step and the Archard
        wear per cycle of both bodies, no stresses and no Dang Van (the iterations of the
        implicit wear, :mod:`micropit_hpc.implicit_wear`). Collective like :meth:`evaluate`,
        with the same arguments; the returned rates are the same on every rank."""
        fields = self.contact_fields(surfaces, pits, warm)
        return self.wear_of(fields, 1), self.wear_of(fields, 2)

    def contact_fields(self, surfaces: tuple[Topography, Topography],
                       pits: tuple[np.ndarray, np.ndarray] | None = None,
                       warm: dict | None = None) -> list[StepFields]:
        """The contact at every step of a load cycle on ``surfaces`` (which become the
        cycle's), on every rank of the group; collective like :meth:`evaluate`, with the same
        arguments."""
        self.set_surfaces(surfaces, pits)
        return self._contact_steps(warm, None)

    def evaluate(self, surfaces: tuple[Topography, Topography],
                 pits: tuple[np.ndarray, np.ndarray] | None = None, warm: dict | None = None,
                 on_step: Callable[[int], None] | None = None) -> CycleResult:
        """One load cycle on ``surfaces`` (docs/model.md §4): contact at every step, stresses and
        Dang Van per body, damage and wear per cycle. Collective over the group (:meth:`solve_step`,
        :meth:`stresses`); the damage of each body holds this rank's slab rows.

        ``surfaces``: both bodies' surfaces as the contact sees them, which become the cycle's
        (:meth:`set_surfaces`); ``pits``: each body's pitted columns that carry no load
        (``life.pit_contact = "unloaded"``; None: none). The counterface's peak spacing λ_c
        (:meth:`~micropit_hpc.surfaces.Topography.peak_spacing_x`, wavelengths below
        ``fatigue.peak_spacing_min_cells`` cells left out) gives the micro-cycles n_μ
        (:func:`micro_cycles`) of ``counting = "sliding"``.

        ``warm``: the contact solver's warm starts by time step, kept by the caller from one
        evaluation to the next (:meth:`solve_step`); :func:`~micropit_hpc.life.run_block`
        keeps them within a block and starts each block without, so that a run restarted from
        a block's checkpoint repeats the straight run's numbers exactly. ``on_step(k)``:
        called after each time step of the contact that this rank solves, k the steps the
        group has solved so far (this rank's count × the ranks sharing them, at most m), for
        progress reports."""
        t0 = time.perf_counter()
        g, fat = self.grid, self.scene.fatigue
        self.set_surfaces(surfaces, pits)
        lam = tuple(s.peak_spacing_x(fat.peak_spacing_min_cells * g.dx) if s.rq > 0
                    else math.inf for s in self.surfaces)
        fields = self._contact_steps(warm, on_step)
        w = self.weights                    # each step's share of the transit time
        p_sum = sum(wj * float(f.pressure.sum()) for wj, f in zip(w, fields, strict=True))
        weights = w * np.array([f.p_mean for f in fields])   # each step's share of the load

        def load_weighted(values) -> float:
            return float((weights * values).sum() / weights.sum()) if weights.any() else 0.0

        phi = load_weighted([f.phi for f in fields])
        pit_load = load_weighted([f.pit_load for f in fields])
        solid = float(sum(wj * f.solid.mean() for wj, f in zip(w, fields, strict=True)))
        at_lim = (1.0 - 1e-9) * self.p_lim
        in_contact = sum(wj * np.count_nonzero(f.pressure > 0.0)
                         for wj, f in zip(w, fields, strict=True))
        plastic = (float(sum(wj * np.count_nonzero(f.pressure >= at_lim)
                             for wj, f in zip(w, fields, strict=True)) / in_contact)
                   if in_contact else 0.0)
        sn = self.woehler
        out = []
        rainflow = fat.counting == "rainflow"
        for body in (1, 2):
            q = sum(wj * float((f.traction1 if body == 1 else f.traction2).sum())
                    for wj, f in zip(w, fields, strict=True))
            mu_signed = q / p_sum if p_sum > 0 else 0.0
            with event("dang_van_macro"):
                macro = dang_van(self.macro_history(body, mu_signed, fat.macro_samples),
                                 alpha=self.alpha_dv)
            tau_smooth = macro.tau_dv                                        # (Nz, 1, ny')
            lam_c = lam[2 - body]                                            # the counterface's
            n_mu = micro_cycles(self, body, lam_c)
            tau, rate, low = self._streamed_dang_van(fields, body, rainflow)
            if not rainflow:
                with event("damage_rate"):
                    rate = sn.damage(tau_smooth) + n_mu * sn.damage(tau)
                    low = sn.low_damage(tau_smooth) + n_mu * sn.low_damage(tau)
            wear = self.wear_of(fields, body)
            out.append(BodyCycle(damage_rate=rate, wear=wear, tau_rough=tau,
                                 tau_smooth=tau_smooth, n_micro=n_mu, lam_c=lam_c,
                                 damage_low=np.broadcast_to(low, rate.shape)))
        return CycleResult(bodies=tuple(out), phi=phi, solid_fraction=solid, steps=self.steps,
                           wall_s=time.perf_counter() - t0, plastic_share=plastic,
                           pit_load=pit_load)
