"""A study: every work item of a scene, run block by block over groups of ranks (MODEL.md §5).

A work item is one (position × wear coefficient × roughness scale × patch) with a stable id
(position-major, in that order). Ranks split into groups of ``ranks_per_item`` contiguous ranks
(:mod:`micropit_hpc.parallel.groups`); every rank computes the same assignment and each group's
ranks run its items together (:mod:`micropit_hpc.parallel.slab`: the group root solves the
contact, every rank its x-slab of the stresses, Dang Van and damage). After every block the
records are gathered on every rank. Results do not depend on the number of groups: an item's
numbers come from its own seeds and its own block loop only (bitwise); with several ranks per
item they equal one rank's to round-off.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from micropit_hpc.conditions import ContactStudy, contact_study
from micropit_hpc.cycle import PositionCycle, body_surface, reference_half_width, window_grid
from micropit_hpc.errors import MicropitError, SceneError, collective
from micropit_hpc.film import iso_lambda_gf
from micropit_hpc.iso6336_22 import method_b
from micropit_hpc.life import (
    BlockRecord,
    LifeParams,
    LifeState,
    initial_state,
    rainflow_steps,
    run_block,
)
from micropit_hpc.regime import block_flags, window_problems
from micropit_hpc.scene import Scene
from micropit_hpc.surfaces import Topography

__all__ = ["MAX_BLOCKS", "SUMMARY_COLUMNS", "ItemRun", "Study", "WorkItem", "block_cycles",
           "life_blocks", "summary_rows", "work_items"]

SUMMARY_COLUMNS = ("item", "position", "S", "p0_GPa", "Lambda", "k_lub_s", "body", "cycles",
                   "Ap_pct", "max_damage", "wear_um", "Rq_um", "lambda_GF", "S_lambda",
                   "slope_dq", "low_cycle_damage_pct", "low_cycle_pits_pct", "p_lim_area_pct",
                   "deep_damage_ratio", "pit_depth_max_um", "flags")


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


def check_life_kinematics(scene: Scene, c) -> None:
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


class ItemRun:
    """The cycle, parameters and evolving state of one work item. ``surfaces``: both bodies'
    patches on the window grid at scale 1 (default: the scene's patch ``item.patch``)."""

    def __init__(self, scene: Scene, item: WorkItem, base: ContactStudy | None = None,
                 log: Callable[[str], None] | None = None, comm=None,
                 surfaces: tuple[Topography, Topography] | None = None):
        self.item = item
        sc = scaled_scene(scene, item.scale)
        study = contact_study(sc) if (base is None or item.scale != 1.0) else base
        check_life_kinematics(scene, study.conditions[item.position - 1])
        b_ref = reference_half_width(study)
        grid = window_grid(sc, b_ref)
        # the patch is made at scale 1 and scaled, so a measured map needs no R_q change
        if surfaces is None:
            surfaces = tuple(body_surface(scene, i, grid, item.patch) for i in (1, 2))
        if item.scale != 1.0:
            surfaces = tuple(s.scaled_to_rq(s.rq * item.scale) if s.rq > 0 else s
                             for s in surfaces)
        self.params = LifeParams.from_scene(scene, item.k_lub)
        steps = scene.window.steps
        if self.params.counting == "rainflow":
            cut = self.params.peak_spacing_min_cells * grid.dx
            lam_c = min(s.peak_spacing_x(cut) if s.rq > 0 else math.inf for s in surfaces)
            steps = rainflow_steps(study.conditions[item.position - 1], steps, lam_c)
            if steps > scene.window.steps and log and (comm is None or comm.rank == 0):
                log(f"item {item.id}: rainflow counting raises the time steps from "
                    f"{scene.window.steps} to {steps} (slip per step ≤ λ_c/4, λ_c = "
                    f"{lam_c * 1e6:.3g} µm)")
        self.surfaces = surfaces
        self.cycle = PositionCycle(study, item.position, surfaces=surfaces, steps=steps,
                                   comm=comm)
        self.state: LifeState = initial_state(self.cycle)

    def run_block(self, cycles: float | None = None,
                  on_progress: Callable[..., None] | None = None) -> BlockRecord:
        return run_block(self.cycle, self.state, self.params, cycles, on_progress)


def summary_rows(item: WorkItem, c, records: Sequence[BlockRecord], lambda_: float,
                 lambda_gf: float = math.nan, lambda_gfp: float = math.nan,
                 z_max: float = math.inf, window_ok: bool = True) -> list[tuple]:
    """Rows of summary.csv (:data:`SUMMARY_COLUMNS`) for one item (contact conditions ``c``),
    one per body and block. ``lambda_gf``: the item's ISO/TS 6336-22 λ_GF; ``S_lambda`` =
    λ_GF/λ_GFP at the item's position (the standard's S_λ is its minimum over the path,
    :mod:`micropit_hpc.iso6336_22`); ``flags``: the block's flags outside the model's range
    (:func:`~micropit_hpc.regime.block_flags`, joined by ``;``, ``none`` inside it)."""
    rows = []
    for r in records:
        flags = ";".join(block_flags(r, z_max, window_ok)) or "none"
        for body in (1, 2):
            i = body - 1
            rows.append((item.id, item.position, c.S, c.p0 / 1e9, lambda_, item.k_lub, body,
                         r.cycles, r.Ap[i], r.max_damage[i], r.wear_mean[i] * 1e6,
                         r.Rq[i] * 1e6, lambda_gf, lambda_gf / lambda_gfp, r.slope[i],
                         100 * r.low_cycle_damage[i], 100 * r.low_cycle_pits[i],
                         100 * r.plastic_share, r.deep_damage[i], r.pit_depth_max[i] * 1e6,
                         flags))
    return rows


class Study:
    """Run every work item of a scene on the ranks of ``comm`` (rank-group parallel).

    Items go round robin to the groups, or longest-first by cost through :meth:`assign` (a
    restart uses the last block's times). The assignment never changes the numbers.
    """

    def __init__(self, scene: Scene, comm, ranks_per_item: int = 1,
                 positions: Sequence[int] | None = None,
                 log: Callable[[str], None] | None = None):
        from micropit_hpc.parallel.groups import assign_items, split_groups

        self.scene, self.comm, self.log = scene, comm, log or (lambda s: None)
        self.base = contact_study(scene)
        self.method_b = method_b(self.base)      # ISO/TS 6336-22 Method B beside A_p
        n_pos = len(self.base.conditions)
        if positions is not None:
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
        self.items = work_items(scene, n_pos, positions)
        for pos in sorted({it.position for it in self.items}):
            check_life_kinematics(scene, self.base.conditions[pos - 1])
        self.group = split_groups(comm, ranks_per_item)
        self.assignment = assign_items(len(self.items), self.group.count)  # round robin
        self.mine = [self.items[i] for i in self.group.items(self.assignment)]
        self.runs: dict[int, ItemRun] = {}
        self._ra: dict[tuple[int, float], tuple[float, float]] = {}
        self.blocks = life_blocks(scene)
        grid, z = self.window()
        self.z_max = float(z[-1])
        #: why the window does not hold the synthetic surfaces (empty when it does)
        self.window_problems = window_problems(scene, grid)
        for p in self.window_problems:
            self.log(f"warning: {scene.source}: the window does not hold the roughness: {p}; "
                     "its R_q and slopes are not the surface's (docs/life.md, \"The model's "
                     "range\")")

    def assign(self, costs: Sequence[float]) -> None:
        """Assign the items longest-first by ``costs`` (before :meth:`setup`)."""
        from micropit_hpc.parallel.groups import assign_items

        if self.runs:
            raise MicropitError("items can only be reassigned before setup()")
        self.assignment = assign_items(len(self.items), self.group.count, costs)
        self.mine = [self.items[i] for i in self.group.items(self.assignment)]

    def setup(self) -> None:
        """Build this group's items (surfaces, solvers, fresh state). Collective."""
        for it in self.mine:
            self.runs[it.id] = ItemRun(self.scene, it, self.base, self.log, self.group.comm)
        if self.runs:   # how each measured map was read (spacing from the file or the scene)
            first = next(iter(self.runs.values()))
            for i, (body, top) in enumerate(zip((self.scene.body1, self.scene.body2),
                                                first.surfaces, strict=True), start=1):
                if body.surface.kind == "file":
                    self.log(f"body{i}.surface: {top.provenance}")

    def block_cycles(self, k: int) -> float:
        """Cycles of block k (1-based): ΔN, the last block shortened so that the blocks add up
        to exactly life.cycles (:func:`life_blocks`)."""
        return block_cycles(self.scene, k)

    def run_block(self, k: int, on_progress: Callable[..., None] | None = None
                  ) -> dict[int, BlockRecord]:
        """Block k of every item of this group; returns {item id: record} on every rank of
        the world, gathered in item order. ``on_progress(k, item, i, n, cycles_done,
        block_cycles, sub_block, step, steps)``: called on every rank of this group after
        every time step (item: the :class:`WorkItem`, i-th of this group's n items)."""
        local = {}
        for i, it in enumerate(self.mine):
            hook = None if on_progress is None else (
                lambda *a, it=it, i=i: on_progress(k, it, i, len(self.mine), *a))
            try:
                rec = self.runs[it.id].run_block(self.block_cycles(k), hook)
            except MicropitError as e:   # say which item failed: the scene may hold dozens
                err = MicropitError(
                    f"{self.scene.source}: item {it.id} (position {it.position}, k_lub "
                    f"{it.k_lub:g} s, roughness × {it.scale:g}, patch {it.patch}), block {k}: "
                    f"{e}")
                # the ranks of a group mostly meet an item's error together: the group root
                # reports it, the others leave it the time to (micropit_hpc.parallel.failure)
                err.group_member = self.group.comm.size > 1 and not self.group.is_root
                raise err from e
            if self.group.is_root:
                local[it.id] = rec
        gathered = self.comm.allgather(local)
        out: dict[int, BlockRecord] = {}
        for part in gathered:
            out.update(part)
        return dict(sorted(out.items()))

    def window(self):
        """(Grid, depth layers z) shared by every item of the study."""
        from micropit_hpc.mechanics.halfspace import depth_layers

        b_ref = reference_half_width(self.base)
        st = self.scene.stress
        return window_grid(self.scene, b_ref), depth_layers(st.layers, st.depth * b_ref,
                                                            st.spacing)

    def item_lambda(self, item: WorkItem) -> float:
        return self.base.conditions[item.position - 1].Lambda / item.scale

    def item_lambda_gf(self, item: WorkItem) -> float:
        """ISO/TS 6336-22 Method B style λ_GF = h_c / ½(R_a1 + R_a2) of the item (MODEL.md
        §6), with the R_a of the item's own initial surfaces (its patch and roughness scale)."""
        key = (item.patch, item.scale)
        if key not in self._ra:
            grid, _ = self.window()
            self._ra[key] = tuple(body_surface(self.scene, i, grid, item.patch).ra * item.scale
                                  for i in (1, 2))
        hc = self.base.conditions[item.position - 1].hc
        return float(iso_lambda_gf(hc, *self._ra[key]))

    def gather_maps(self) -> dict[int, dict[str, np.ndarray]]:
        """The final maps of every item on world rank 0 (None elsewhere)."""
        local = {}
        for iid, run in self.runs.items():
            maps = {}
            for i, b in enumerate(run.state.bodies, start=1):
                damage = run.cycle.slab.gather(b.damage)
                if self.group.is_root:
                    maps[f"body{i}/heights"] = b.heights
                    maps[f"body{i}/damage"] = damage
                    maps[f"body{i}/damage_risk"] = damage.max(axis=0)
                    maps[f"body{i}/pitted"] = b.pitted.astype(np.uint8)
                    maps[f"body{i}/wear"] = b.wear
                    maps[f"body{i}/pit_depth"] = b.pit_depth
            if self.group.is_root:
                local[iid] = maps
        parts = self.comm.gather(local, root=0)
        if self.comm.rank != 0:
            return {}
        out = {}
        for part in parts:
            out.update(part)
        return dict(sorted(out.items()))

