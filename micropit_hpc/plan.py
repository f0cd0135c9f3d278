"""The plan of a study: everything a scene implies before the first load cycle is solved.

Scene → :class:`Plan`: the contact conditions of every position (:mod:`micropit_hpc.conditions`),
the frozen computational :class:`Window` (grid, depth layers, b_ref) shared by every work item,
the work items, the contact level of each position, the blocks of the life, the ISO/TS 6336-22
Method B baseline, and **every** check that needs more than one key: ``micropit scene``,
``micropit run`` and ``micropit snapshot`` all build the plan, so a scene that ``micropit scene``
calls valid is one that ``micropit run`` accepts (docs/architecture.md).

Nothing here solves a contact or touches MPI: the plan is the same on every rank, so its errors
are raised on every rank alike (:class:`~micropit_hpc.errors.SceneError` is collective).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from micropit_hpc.conditions import ContactConditions, ContactStudy, contact_study
from micropit_hpc.errors import MicropitError, SceneError, collective
from micropit_hpc.hertz import line_contact
from micropit_hpc.lubrication import LEVELS
from micropit_hpc.mechanics.halfspace import depth_layers
from micropit_hpc.regime import window_problems
from micropit_hpc.scene import Scene, check_mixed_inputs
from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces.bodies import body_surface

__all__ = ["LEVELS", "MAX_BLOCKS", "Plan", "Window", "WorkItem", "block_cycles",
           "check_life_kinematics", "choose_level", "life_blocks", "make_plan",
           "reference_half_width", "scaled_scene", "window_grid", "work_items"]



# ---- the window ------------------------------------------------------------------------------
def reference_half_width(study: ContactStudy) -> float:
    """b_ref: the Hertz semi-width at the pitch point of a gear pair (same window at every
    position, as in the paper), or of the first contact of a disc rig (docs/model.md §4)."""
    scene = study.scene
    if study.mesh is None:
        return study.conditions[0].b
    mesh, gear = study.mesh, scene.gear
    rho_p = mesh.C
    X = float(mesh.load_share(np.array([rho_p]), gear.load_sharing, gear.accuracy_grade)[0])
    w = X * gear.torque / (gear.geometry.base_radius1 * gear.geometry.facewidth)
    b, _ = line_contact(w, float(mesh.reduced_radius(np.array([rho_p]))[0]), study.E_star)
    return float(b)


def window_grid(scene: Scene, b_ref: float) -> Grid:
    """The window grid of a scene ([window] keys; lengths default to 2 b_ref)."""
    w = scene.window
    lx = w.lx if w.lx is not None else 2.0 * b_ref
    ly = w.ly if w.ly is not None else lx
    return Grid(w.nx, w.ny if w.ny is not None else w.nx, lx, ly)


@dataclass(frozen=True, eq=False)
class Window:
    """The computational window every work item of a study shares (docs/model.md §4, §4.2):
    the grid, the depth layers z [m] (``stress.layers`` to ``stress.depth_b`` × b_ref) and the
    reference semi-width b_ref [m] they derive from."""

    grid: Grid
    z: np.ndarray
    b_ref: float

    @property
    def z_max(self) -> float:
        """The deepest stress layer [m]."""
        return float(self.z[-1])

    @classmethod
    def of(cls, study: ContactStudy) -> Window:
        """The window of the scene of ``study`` (the one place it is derived)."""
        b_ref = reference_half_width(study)
        st = study.scene.stress
        z = depth_layers(st.layers, st.depth * b_ref, st.spacing)
        z.setflags(write=False)
        return cls(window_grid(study.scene, b_ref), z, b_ref)


# ---- contact levels --------------------------------------------------------------------------
def choose_level(scene: Scene, c: ContactConditions, rough: bool) -> str:
    """The contact level of a position: the scene's, or for ``auto`` smooth when the surfaces
    are smooth or Λ ≥ auto_lambda (full film) and mixed otherwise (docs/model.md §0, §4.1).
    The mixed level checks that the lubricant's rheology is given."""
    model = scene.lubrication.model
    if model == "auto":
        model = "smooth" if (not rough or c.Lambda >= scene.lubrication.auto_lambda) else "mixed"
    if model == "mixed":
        check_mixed_inputs(scene, 'lubrication.model = "mixed"' if scene.lubrication.model ==
                           "mixed" else f"Λ = {c.Lambda:.3g} < lubrication.auto_lambda makes "
                           '"auto" choose "mixed"')
    return model


def declared_rough(scene: Scene) -> bool:
    """Whether the scene gives either body a roughness (before any surface is made)."""
    return any(b.Rq > 0.0 and b.surface.kind != "smooth" for b in (scene.body1, scene.body2))


# ---- work items and blocks -------------------------------------------------------------------
@dataclass(frozen=True)
class WorkItem:
    """One independent life simulation of a study."""

    id: int
    position: int
    k_lub: float
    scale: float
    patch: int


def work_items(scene: Scene, n_positions: int,
               positions: Sequence[int] | None = None) -> list[WorkItem]:
    """All work items, ids in the order position → k_lub → roughness scale → patch."""
    chosen = range(1, n_positions + 1) if positions is None else positions
    items = []
    for pos in chosen:
        for k in scene.wear.k_lub:
            for s in scene.roughness_scale:
                for p in range(scene.patches):
                    items.append(WorkItem(len(items), pos, k, s, p))
    return items


def scaled_scene(scene: Scene, scale: float) -> Scene:
    """The scene with both bodies' R_q multiplied by ``scale`` (Λ scales as 1/scale)."""
    if scale == 1.0:
        return scene
    return replace(scene, body1=replace(scene.body1, Rq=scene.body1.Rq * scale),
                   body2=replace(scene.body2, Rq=scene.body2.Rq * scale))


#: The most blocks a run may have: each block is a checkpoint row and a record per item.
MAX_BLOCKS = 10_000
#: A remainder below this fraction of a block is round-off of the decimal inputs, not a block.
BLOCK_ROUND_OFF = 1e-9


def life_blocks(scene: Scene) -> int:
    """The number of blocks that reach exactly ``life.cycles``: ⌈cycles / ΔN⌉, the last one
    shorter when ΔN does not divide the life (a remainder below 1e-9 ΔN is round-off). A scene
    that would need more than :data:`MAX_BLOCKS` blocks is refused."""
    life = scene.life
    ratio = life.cycles / life.block
    blocks = max(1, math.ceil(ratio * (1 - BLOCK_ROUND_OFF)))
    if blocks > MAX_BLOCKS:
        raise SceneError(scene.source, f"the life of {life.cycles / 1e6:g} M cycles in blocks "
                         f"of {life.block / 1e6:g} M is {ratio:.4g} blocks, more than a run can "
                         f"checkpoint and record ({MAX_BLOCKS})", key="life.block_M",
                         value=life.block / 1e6,
                         allowed=f"≥ life.cycles_M / {MAX_BLOCKS} = "
                                 f"{life.cycles / 1e6 / MAX_BLOCKS:g}")
    return blocks


def block_cycles(scene: Scene, k: int) -> float:
    """Cycles of block ``k`` (1-based) of :func:`life_blocks`: ΔN, and for the last block what
    is left of the life (so that the cycles add up to life.cycles exactly)."""
    life = scene.life
    n = life_blocks(scene)
    if not 1 <= k <= n:
        raise MicropitError(f"block {k} outside 1 … {n}")
    return life.block if k < n else life.cycles - (n - 1) * life.block


def check_life_kinematics(scene: Scene, c: ContactConditions) -> None:
    """Refuse a position whose surface is at rest (pure sliding): it never completes a load
    cycle, so its cycles cannot be counted."""
    if min(c.u1, c.u2) <= 0.0:
        pos = c.position
        key, value = ("disc.slide_roll", scene.disc.slide_roll[pos - 1]) \
            if scene.disc is not None else (f"position {pos}", c.S)
        raise SceneError(
            scene.source, f"a surface at rest (u1 = {c.u1:.3g}, u2 = {c.u2:.3g} m/s, "
            "pure sliding) never completes a load cycle, so a life simulation cannot "
            "count its cycles (`micropit contact` still works)", key=key, value=value,
            allowed="|S| < 2 for `micropit run`")


def check_positions(scene: Scene, positions: Sequence[int], n_pos: int) -> None:
    """``--position`` options: each an existing position, each once."""
    bad = [p for p in positions if not 1 <= p <= n_pos]
    if bad:
        raise collective(MicropitError(
            f"--position {bad[0]}: position {bad[0]} does not exist ({scene.source} has "
            f"positions 1 to {n_pos})"))
    if len(set(positions)) != len(positions):
        twice = sorted({p for p in positions if list(positions).count(p) > 1})
        raise collective(MicropitError(
            f"--position {twice[0]} is given more than once: each position is one set "
            "of work items; give every position once"))


def check_surfaces(scene: Scene, grid: Grid) -> None:
    """Read every measured map the scene names, as a run would: a missing, unreadable or
    unusable file (its R_q, its size against the window) is refused here, not at the first
    block. Synthetic surfaces cannot fail and are not made here."""
    from micropit_hpc.estimate import available_memory, npy_too_large

    problem = npy_too_large(scene, available_memory())
    if problem:
        raise SceneError("", problem)
    for i, body in ((1, scene.body1), (2, scene.body2)):
        if body.surface.kind == "file" and body.Rq > 0.0:
            body_surface(scene, i, grid)


# ---- the plan --------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Plan:
    """A checked study, before anything is solved: the scene, its contact conditions
    (``study``), the shared :class:`Window`, the work items, the contact level of every
    position, the blocks of the life, the ISO/TS 6336-22 Method B baseline (``method_b``) and
    why the window does not hold the synthetic roughness (``window_problems``, warnings) and
    other plausibility warnings (``warnings``)."""

    scene: Scene
    study: ContactStudy
    window: Window
    items: tuple[WorkItem, ...]
    levels: tuple[str, ...]
    blocks: int
    method_b: object
    window_problems: tuple[str, ...]
    #: values in range that cannot be meant (a p0 no steel carries, a correlation length
    #: smaller than a grid cell): :func:`plausibility_warnings`
    warnings: tuple[str, ...] = ()

    def conditions(self, position: int) -> ContactConditions:
        """The contact conditions of ``position`` (1-based)."""
        return self.study.conditions[position - 1]

    def block_cycles(self, k: int) -> float:
        """Cycles of block k (1-based), :func:`block_cycles`."""
        return block_cycles(self.scene, k)

    def item_lambda(self, item: WorkItem) -> float:
        """Λ of an item: its position's, over its roughness scale."""
        return self.conditions(item.position).Lambda / item.scale

    def queue_order(self) -> list[int]:
        """The order in which the dynamic balance hands out a block's items, the likely
        costliest first (indices into :attr:`items`). The key, without fitted weights: the
        wear coefficient k_lub (an item with wear also runs the implicit wear's contact-only
        load cycles, more of them the faster it wears), then the surfaces' relative slip
        over the transit 2b|S| (the load cycle's time steps and the wear rate grow with it),
        then the roughness scale, then the item's id. Started in this order, the costliest
        items no longer start last and leave one group to finish them alone; a measured
        block's times predict the next block's worse than this key does, as items' costs
        change from block to block (docs/hpc.md §2, "Level 1"; the replay of a study's times
        in docs/performance.md §3)."""
        def key(i: int):
            it = self.items[i]
            c = self.conditions(it.position)
            return (-it.k_lub, -2.0 * c.b * abs(c.S), -it.scale, it.id)

        return sorted(range(len(self.items)), key=key)


def make_plan(scene: Scene, positions: Sequence[int] | None = None, *,
              life: bool = True) -> Plan:
    """Build and check the :class:`Plan` of ``scene`` (every rank alike). ``positions``: the
    ``--position`` choice (default all); ``life``: check what a life simulation needs beyond a
    contact (surfaces that move, a life of not too many blocks)."""
    from micropit_hpc.iso6336_22 import method_b

    study = contact_study(scene)
    n_pos = len(study.conditions)
    if positions is not None:
        check_positions(scene, positions, n_pos)
    items = tuple(work_items(scene, n_pos, positions))
    chosen = sorted({it.position for it in items})
    blocks = life_blocks(scene) if life else 0
    if life:
        for pos in chosen:
            check_life_kinematics(scene, study.conditions[pos - 1])
    rough = declared_rough(scene)
    levels = tuple(choose_level(scene, c, rough) for c in study.conditions)
    window = Window.of(study)
    check_surfaces(scene, window.grid)
    return Plan(scene=scene, study=study, window=window, items=items, levels=levels,
                blocks=blocks, method_b=method_b(study),
                window_problems=tuple(window_problems(scene, window.grid)),
                warnings=tuple(plausibility_warnings(scene, study, window.grid)))


#: The largest Hertz pressure any steel carries [Pa]: the hardness of the hardest bearing and
#: case-hardened steels (HV 800 ≈ 7.8 GPa); real gear and bearing contacts run at 0.5–3 GPa.
P0_STEEL_MAX = 8e9


#: The fewest grid cells per ``fatigue.process_length_um`` at which the averaging, and not the
#: cell, sets the shortest length of the stresses: its discrete Gaussian of variance ℓ²/12
#: (:func:`~micropit_hpc.spectral.discrete_gaussian`) keeps exp(−(ℓ/Δx)²/6) of the Nyquist
#: wave π/Δx along an axis, 69 % at 1.5 cells (85 % at one cell). At 1.56 cells (5 µm on the
#: paper gear's 64² window) the measured wear and A_p were within the convergence bands of 128²
#: (docs/life.md, "A process length for the criterion").
PROCESS_MIN_CELLS = 1.5


def plausibility_warnings(scene: Scene, study: ContactStudy, grid) -> list[str]:
    """Warnings for a scene whose values are allowed but cannot be meant, once the contact and
    the window are known: a Hertz pressure no steel carries (a torque in N·mm, a facewidth in
    m), in-plane lengths of a synthetic surface shorter than a grid cell (the grid does not
    resolve them; often a value in metres), and a process length of the fatigue criterion
    below :data:`PROCESS_MIN_CELLS` cells (the averaging does not yet act)."""
    out = []
    src = scene.source
    p0s = [c.p0 for c in study.conditions]
    if p0s and max(p0s) > P0_STEEL_MAX:
        k = max(range(len(p0s)), key=p0s.__getitem__)
        if scene.gear is not None:
            keys = (f"gear.torque_Nm = {scene.gear.torque:g} (N·m) and gear.facewidth_mm = "
                    f"{scene.document.get('gear', {}).get('facewidth_mm', '?')}")
        else:
            keys = "the [disc] load"
        out.append(f"{src}: p0 = {p0s[k] / 1e9:.3g} GPa at position {k + 1} is above what "
                   f"any steel carries (about {P0_STEEL_MAX / 1e9:g} GPa, the hardness of the "
                   f"hardest steels; gears run at 0.5 to 3 GPa): check {keys}")
    cell = {"x": grid.lx / grid.nx, "y": grid.ly / grid.ny}
    for i, body in ((1, scene.body1), (2, scene.body2)):
        s = body.surface
        if body.Rq == 0.0:
            continue
        lengths = []
        if s.kind == "gaussian":
            lengths = [("corr_x_um", s.corr_x, "x"), ("corr_y_um", s.corr_y, "y")]
        elif s.kind == "self_affine" and s.short_cutoff is not None:
            lengths = [("short_cutoff_um", s.short_cutoff, "x")]
        for key, value, axis in lengths:
            if math.isfinite(value) and value < cell[axis]:
                out.append(f"{src}: body{i}.surface.{key} = {value * 1e6:.3g} µm is shorter "
                           f"than one grid cell along {axis} ({cell[axis] * 1e6:.3g} µm): the "
                           f"grid cannot resolve it (raise window.n, or check the unit)")
    ell, coarse = scene.fatigue.process_length, max(cell.values())
    cells = ell / coarse
    if 0.0 < ell and cells < PROCESS_MIN_CELLS:
        given = "process_length_um" in (scene.document.get("fatigue") or {})
        whose = "" if given else (f" (the default of life.integration = "
                                  f"\"{scene.life.integration}\")")
        out.append(f"{src}: fatigue.process_length_um = {ell * 1e6:.3g} µm{whose} is "
                   f"{cells:.2g} grid cells ({coarse * 1e6:.3g} µm): the averaging keeps "
                   f"{100 * math.exp(-cells * cells / 6):.0f} % of the shortest "
                   f"wave, so the cell still acts as the process area and the pits can "
                   f"follow the grid (raise window.n until the length spans "
                   f"{PROCESS_MIN_CELLS:g} cells, or set the length; "
                   f"docs/life.md, \"A process length for the criterion\")")
    return out
