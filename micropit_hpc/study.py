"""A study: every work item of a scene, run block by block over groups of ranks (docs/model.md §5).

A work item is one (position × wear coefficient × roughness scale × patch) with a stable id
(position-major, in that order). Ranks split into groups of ``ranks_per_item`` contiguous ranks
(:mod:`micropit_hpc.parallel.groups`); each group's ranks run its items together
(:mod:`micropit_hpc.parallel.slab`: every rank its x-slab of the contact, the stresses, Dang Van
and damage). Which group runs which item (``balance``, docs/hpc.md §2): ``"dynamic"`` hands
every block's items out as groups free up, the likely costliest first
(:meth:`Plan.queue_order <micropit_hpc.plan.Plan.queue_order>`), an item's state going with it
to the group that takes it; ``"static"`` keeps the first
assignment (round robin, or a restart's longest-first). After every block the
records are gathered on every rank. Results do not depend on the groups: an item's numbers come
from its own seeds and its own block loop only (bitwise, wherever it runs and however often it
moves); with several ranks per item they equal one rank's to round-off.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from micropit_hpc.conditions import ContactStudy, contact_study
from micropit_hpc.cycle import PositionCycle, counterface_spacing, cycle_steps
from micropit_hpc.errors import MicropitError
from micropit_hpc.film import iso_lambda_gf
from micropit_hpc.io.results import SUMMARY_UNITS
from micropit_hpc.life import BlockRecord, LifeState, initial_state, run_block
from micropit_hpc.plan import (
    Plan,
    Window,
    WorkItem,
    check_life_kinematics,
    make_plan,
    scaled_scene,
)
from micropit_hpc.regime import block_flags
from micropit_hpc.running_in import RunningIn, run_in
from micropit_hpc.scene import Scene
from micropit_hpc.state import BODY_FIELDS, carried, restore_carried
from micropit_hpc.surfaces import Topography
from micropit_hpc.surfaces.bodies import body_surface

__all__ = ["SUMMARY_COLUMNS", "ItemRun", "Study", "summary_rows"]

#: How the work items are spread over the groups (:class:`Study`, ``micropit run --balance``).
BALANCE = ("dynamic", "static")
#: ``balance = "dynamic"`` hands out every block's items as groups free up while what every
#: item carries (:func:`~micropit_hpc.state.carried`) fits this on every rank; beyond it, the
#: items are moved longest-first by the last block's times (:meth:`Study.reassign`).
SHARE_BYTES = 256 * 2 ** 20

#: The columns of summary.csv, in order: the keys of their declaration with units
#: (:data:`micropit_hpc.io.results.SUMMARY_UNITS`).
SUMMARY_COLUMNS = tuple(SUMMARY_UNITS)


class ItemRun:
    """The cycle and evolving state of one work item. ``surfaces``: both bodies' patches on
    the window grid at scale 1 (default: the scene's patch ``item.patch``). The settings are
    the scene's: ``life`` (``scene.life``) for the blocks, the cycle's (``scene.fatigue``,
    ``scene.wear`` and the item's k_lub) for the load cycle."""

    def __init__(self, scene: Scene, item: WorkItem, base: ContactStudy | None = None,
                 log: Callable[[str], None] | None = None, comm=None,
                 surfaces: tuple[Topography, Topography] | None = None,
                 window: Window | None = None):
        self.item = item
        sc = scaled_scene(scene, item.scale)
        study = contact_study(sc) if (base is None or item.scale != 1.0) else base
        check_life_kinematics(scene, study.conditions[item.position - 1])
        window = Window.of(study) if window is None else window
        grid = window.grid
        # the patch is made at scale 1 and scaled, so a measured map needs no R_q change
        if surfaces is None:
            surfaces = tuple(body_surface(scene, i, grid, item.patch) for i in (1, 2))
        if item.scale != 1.0:
            surfaces = tuple(s.scaled_to_rq(s.rq * item.scale) if s.rq > 0 else s
                             for s in surfaces)
        self.life = scene.life          # the blocks' settings: the scene's [life], not a copy
        # the floor window.steps, raised by the kinematics (docs/model.md §4): the same rule
        # as a PositionCycle without steps, on every rank of the group alike
        steps, why = cycle_steps(scene, study.conditions[item.position - 1],
                                 counterface_spacing(scene, surfaces, grid.dx))
        if why and log and (comm is None or comm.rank == 0):
            log(f"item {item.id} (position {item.position}): the time steps raised from "
                f"{scene.window.steps} to {steps} ({why})")
        self.surfaces = surfaces
        self.cycle = PositionCycle(study, item.position, surfaces=surfaces, steps=steps,
                                   comm=comm, window=window, k_lub=item.k_lub)
        self.state: LifeState = initial_state(self.cycle)
        self._log, self._rank = log, (0 if comm is None else comm.rank)
        #: what the plastic running-in did (``life.running_in = "plastic"``), once it ran
        self.running_in: RunningIn | None = None

    def run_block(self, cycles: float | None = None,
                  on_progress: Callable[..., None] | None = None) -> BlockRecord:
        """The next block (:func:`~micropit_hpc.life.run_block`); before the first block of
        a fresh state the plastic running-in (``life.running_in``), which a run restarted
        from a checkpoint does not repeat (its surfaces hold it). ``on_progress`` as
        run_block's; during the running-in it is called after each pass k as
        ``on_progress(0, block_cycles, 0, k, running_in_passes)`` (sub-block 0)."""
        if self.life.running_in == "plastic" and self.state.block == 0 \
                and self.running_in is None:
            say = self._log if self._log and self._rank == 0 else (lambda s: None)
            who = f"item {self.item.id} (position {self.item.position})"
            say(f"{who}: plastic running-in, up to {self.life.running_in_passes} contact-only "
                "load cycles")
            total = self.life.block if cycles is None else cycles
            tick = None if on_progress is None else (
                lambda k: on_progress(0.0, total, 0, k, self.life.running_in_passes))
            self.running_in = run_in(self.cycle, self.state, self.life, tick)
            say(f"{who}: {self.running_in.line()}")
        return run_block(self.cycle, self.state, self.life, cycles, on_progress)


def summary_rows(item: WorkItem, c, records: Sequence[BlockRecord], lambda_: float,
                 lambda_gf: float = math.nan, lambda_gfp: float = math.nan,
                 z_max: float = math.inf, window_ok: bool = True,
                 wear_tol: float = math.inf) -> list[tuple]:
    """Rows of summary.csv (:data:`SUMMARY_COLUMNS`) for one item (contact conditions ``c``),
    one per body and block. ``lambda_gf``: the item's ISO/TS 6336-22 λ_GF; ``S_lambda`` =
    λ_GF/λ_GFP at the item's position (the standard's S_λ is its minimum over the path,
    :mod:`micropit_hpc.iso6336_22`); ``flags``: the block's flags outside the model's range
    (:func:`~micropit_hpc.regime.block_flags`, joined by ``;``, ``none`` inside it)."""
    rows = []
    for r in records:
        flags = ";".join(block_flags(r, z_max, window_ok, wear_tol)) or "none"
        for body in (1, 2):
            i = body - 1
            rows.append((item.id, item.position, c.S, c.p0 / 1e9, lambda_, item.k_lub, body,
                         r.cycles, r.Ap[i], r.max_damage[i], r.wear_mean[i] * 1e6,
                         r.Rq[i] * 1e6, lambda_gf, lambda_gf / lambda_gfp, r.slope[i],
                         100 * r.low_cycle_damage[i], 100 * r.low_cycle_pits[i],
                         100 * r.plastic_share, r.deep_damage[i], r.pit_depth_max[i] * 1e6,
                         r.phi, 100 * r.pit_load, r.sub_blocks, r.wear_cycles, flags))
    return rows


class Study:
    """Run every work item of a scene on the ranks of ``comm`` (rank-group parallel).

    Items go round robin to the groups, or longest-first by cost through :meth:`assign` (a
    restart uses the last block's times); with ``balance = "dynamic"`` (more than one group)
    every block hands them out as groups free up instead, the likely costliest first
    (:meth:`_run_queued`, :meth:`Plan.queue_order <micropit_hpc.plan.Plan.queue_order>`;
    where the items' states are too large to share, later blocks reassign them longest-first
    by the block before, :meth:`reassign`). No group holds more than ⌈items/groups⌉. The
    assignment never changes the numbers.
    """

    def __init__(self, scene: Scene, comm, ranks_per_item: int = 1,
                 positions: Sequence[int] | None = None,
                 log: Callable[[str], None] | None = None, plan: Plan | None = None,
                 balance: str = "dynamic"):
        from micropit_hpc.parallel.groups import assign_items, fair_share, split_groups

        if balance not in BALANCE:
            raise MicropitError(f"balance {balance!r}: expected one of {', '.join(BALANCE)}")
        self.scene, self.comm, self.log = scene, comm, log or (lambda s: None)
        self.plan = make_plan(scene, positions) if plan is None else plan
        self.base = self.plan.study
        self.method_b = self.plan.method_b       # ISO/TS 6336-22 Method B beside A_p
        self.items = list(self.plan.items)
        self.group = split_groups(comm, ranks_per_item)
        self.most = fair_share(len(self.items), self.group.count)
        self.assignment = assign_items(len(self.items), self.group.count)  # round robin
        self.mine = [self.items[i] for i in self.group.items(self.assignment)]
        self.runs: dict[int, ItemRun] = {}
        #: moving items between groups: every block from the shared queue (or, states too
        #: large to share, later blocks reassigned longest-first by :attr:`costs`)
        self.dynamic = balance == "dynamic" and self.group.count > 1
        self.queued = self.dynamic          # the next block's items from the queue
        #: each item's time in the last block run (set after every block)
        self.costs: list[float] | None = None
        self._told = False
        self._ra: dict[tuple[int, float], tuple[float, float]] = {}
        self.blocks = self.plan.blocks
        self.z_max = self.plan.window.z_max
        #: why the window does not hold the synthetic surfaces (empty when it does)
        self.window_problems = list(self.plan.window_problems)
        for p in self.window_problems:
            self.log(f"warning: {scene.source}: the window does not hold the roughness: {p}; "
                     "its R_q and slopes are not the surface's (docs/life.md, \"The model's "
                     "range\")")

    def assign(self, costs: Sequence[float] | None) -> None:
        """Assign the items longest-first by ``costs`` (None: round robin) before
        :meth:`setup`, for the first block too (a restart: no queue)."""
        from micropit_hpc.parallel.groups import assign_items

        if self.runs:
            raise MicropitError("items can only be reassigned before setup()")
        self.assignment = assign_items(len(self.items), self.group.count, costs, self.most)
        self.mine = [self.items[i] for i in self.group.items(self.assignment)]
        self.queued = False

    def setup(self) -> None:
        """Build this group's items (surfaces, solvers, fresh state; none yet where the first
        block takes them from the queue). Collective."""
        for it in ([] if self.queued else self.mine):
            self.runs[it.id] = self._build(it)

    def _build(self, item: WorkItem, log: bool = True) -> ItemRun:
        """A fresh run of ``item`` on this group (collective over it); ``log``: say what its
        set-up decides (not for an item moved here, whose first group said it)."""
        run = ItemRun(self.scene, item, self.base, self.log if log else None,
                      self.group.comm, window=self.plan.window)
        if not self._told:   # how each measured map was read (spacing from the file or scene)
            self._told = True
            for i, (body, top) in enumerate(zip((self.scene.body1, self.scene.body2),
                                                run.surfaces, strict=True), start=1):
                if body.surface.kind == "file":
                    self.log(f"body{i}.surface: {top.provenance}")
        return run

    def reassign(self, assignment: Sequence[Sequence[int]]) -> None:
        """Run the items as ``assignment`` (an :func:`assign_items` result) says from now on.
        Collective over the world. An item that changes group is rebuilt there from what it
        carries from block to block (:func:`carried`: the checkpoint's content, so this is a
        restart's path and changes no number), sent over by
        :func:`~micropit_hpc.parallel.groups.move_items`."""
        from micropit_hpc.parallel.groups import move_items

        arrived = {}

        def receive(i: int) -> list[np.ndarray]:
            run = self._build(self.items[i], log=False)
            arrived[i] = (run, [np.empty_like(a) for a in carried(run.state)])
            return arrived[i][1]

        new = [sorted(ids) for ids in assignment]
        move_items(self.group, self.assignment, new,
                   lambda i: carried(self.runs.pop(self.items[i].id).state), receive)
        for i, (run, parts) in arrived.items():
            restore_carried(run.state, parts)
            self.runs[self.items[i].id] = run
        self.assignment = new
        self.mine = [self.items[i] for i in self.group.items(new)]

    def block_cycles(self, k: int) -> float:
        """Cycles of block k (1-based): ΔN, the last block shortened so that the blocks add up
        to exactly life.cycles (:func:`life_blocks`)."""
        return self.plan.block_cycles(k)

    def run_block(self, k: int, on_progress: Callable[..., None] | None = None
                  ) -> dict[int, BlockRecord]:
        """Block k of every item of this group; returns {item id: record} on every rank of
        the world, gathered in item order. ``on_progress(k, item, i, n, cycles_done,
        block_cycles, sub_block, step, steps, queued)``: called on every rank of this group
        after every time step (item: the :class:`WorkItem`, i-th of this group's n items, or,
        ``queued``, the i-th handed out of the block's n).
        With ``balance = "dynamic"`` the groups take the items from a queue, likely costliest
        first (:meth:`Plan.queue_order <micropit_hpc.plan.Plan.queue_order>`; after the first
        block the states shared: :meth:`_share`), or, where the states are too large to share,
        the items are first reassigned longest-first by the last block's times
        (:meth:`reassign`)."""
        from micropit_hpc.parallel.groups import assign_items

        local, queue = {}, None
        if self.queued:                     # the first block: nothing held yet
            queue = (self.plan.queue_order(), {})
        elif self.dynamic and self.costs is not None:
            copies = self._share()
            if copies is None:              # too large to share: moved longest-first
                self.reassign(assign_items(len(self.items), self.group.count, self.costs,
                                           self.most))
            else:
                queue = (self.plan.queue_order(), copies)
        if queue is not None:
            local = self._run_queued(k, on_progress, *queue)
        else:
            for i, it in enumerate(self.mine):
                local[it.id] = self._run_item(k, it, i, len(self.mine), on_progress)
        gathered = self.comm.allgather((self.group.index, local if self.group.is_root else {}))
        out: dict[int, BlockRecord] = {}
        for _, part in gathered:
            out.update(part)
        if queue is not None:               # who ran what: where each item's state now lives
            self.assignment = [[] for _ in range(self.group.count)]
            for g, part in gathered:
                self.assignment[g] += sorted(part)
            self.queued = False
        self.costs = [out[it.id].wall_s for it in self.items]
        return dict(sorted(out.items()))

    def _share(self) -> dict[int, list] | None:
        """What every item carries (:func:`carried`), on every group (rank j of each from rank
        j of the item's), or None where that would hold more than :data:`SHARE_BYTES` per
        rank. Collective over the world."""
        from micropit_hpc.parallel.groups import share_items

        held = {i.id: carried(self.runs[i.id].state) for i in self.mine}
        size = sum(a.nbytes for parts in held.values() for a in parts)
        if self.comm.allreduce(size) > SHARE_BYTES * self.group.size:
            return None
        return share_items(self.group, held)

    def _run_queued(self, k: int, on_progress, order, copies: dict[int, list]
                    ) -> dict[int, BlockRecord]:
        """Block k of the items this group takes from the queue in ``order``
        (:class:`~micropit_hpc.parallel.groups.ItemQueue`): an item it does not hold is built
        here and, after the first block, set from its shared ``copies`` (:meth:`_share`); the
        items it held and another group ran are dropped."""
        from micropit_hpc.parallel.groups import ItemQueue

        queue = ItemQueue(self.group, len(self.items), self.most, order)
        local, runs, self.mine = {}, {}, []
        while (taken := queue.take()) is not None:
            it = self.items[taken[0]]
            run = self.runs.get(it.id)
            if run is None:
                run = self._build(it, log=not copies)
                if copies:
                    restore_carried(run.state, copies[it.id])
            runs[it.id] = self.runs[it.id] = run
            self.mine.append(it)
            local[it.id] = self._run_item(k, it, taken[1], len(self.items), on_progress, True)
        queue.close()
        self.runs = runs
        self.mine.sort(key=lambda it: it.id)
        return local

    def _run_item(self, k: int, it: WorkItem, i: int, n: int, on_progress, queued=False
                  ) -> BlockRecord:
        """Block k of item ``it``, the i-th of n (of this group's, or of the ``queued``)."""
        hook = None if on_progress is None else (
            lambda *a: on_progress(k, it, i, n, *a, queued))
        try:
            return self.runs[it.id].run_block(self.block_cycles(k), hook)
        except MicropitError as e:   # say which item failed: the scene may hold dozens
            err = MicropitError(
                f"{self.scene.source}: item {it.id} (position {it.position}, k_lub "
                f"{it.k_lub:g} s, roughness × {it.scale:g}, patch {it.patch}), block {k}: "
                f"{e}")
            # the ranks of a group mostly meet an item's error together: the group root
            # reports it, the others leave it the time to (micropit_hpc.parallel.failure)
            err.group_member = self.group.comm.size > 1 and not self.group.is_root
            raise err from e

    def item_lambda(self, item: WorkItem) -> float:
        return self.plan.item_lambda(item)

    def item_lambda_gf(self, item: WorkItem) -> float:
        """ISO/TS 6336-22 Method B style λ_GF = h_c / ½(R_a1 + R_a2) of the item (docs/model.md
        §6), with the R_a of the item's own initial surfaces (its patch and roughness scale)."""
        key = (item.patch, item.scale)
        if key not in self._ra:
            grid = self.plan.window.grid
            self._ra[key] = tuple(body_surface(self.scene, i, grid, item.patch).ra * item.scale
                                  for i in (1, 2))
        hc = self.base.conditions[item.position - 1].hc
        return float(iso_lambda_gf(hc, *self._ra[key]))

    #: the columns of :meth:`summary`
    summary_columns = SUMMARY_COLUMNS

    def summary(self, records: Mapping[int, Sequence[BlockRecord]]) -> list[tuple]:
        """The rows of summary.csv (:data:`SUMMARY_COLUMNS`) of every item, in item order."""
        rows = []
        for it in self.items:
            rows += summary_rows(it, self.base.conditions[it.position - 1], records[it.id],
                                 self.item_lambda(it), lambda_gf=self.item_lambda_gf(it),
                                 lambda_gfp=self.method_b.lambda_gfp, z_max=self.z_max,
                                 window_ok=not self.window_problems,
                                 wear_tol=self.scene.life.wear_tol)
        return rows

    def gather_maps(self) -> dict[int, dict[str, np.ndarray]]:
        """The final maps of every item on world rank 0 (None elsewhere)."""
        local = {}
        for iid, run in self.runs.items():
            maps = {}
            for i, b in enumerate(run.state.bodies, start=1):
                for f in BODY_FIELDS:
                    value = getattr(b, f.name)
                    if f.layered:
                        value = run.cycle.slab.gather(value)
                    if self.group.is_root:
                        maps[f"body{i}/{f.name}"] = value.astype(f.dtype, copy=False)
                        if f.name == "damage":   # the worst layer of each column
                            maps[f"body{i}/damage_risk"] = value.max(axis=0)
            if self.group.is_root:
                local[iid] = maps
        parts = self.comm.gather(local, root=0)
        if self.comm.rank != 0:
            return {}
        out = {}
        for part in parts:
            out.update(part)
        return dict(sorted(out.items()))

