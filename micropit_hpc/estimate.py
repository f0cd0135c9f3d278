"""An up-front estimate of a run's memory and time, printed before the run and refused, with
the estimate, when it exceeds the memory this node gives the job (docs/jobs.md).

The model is fitted to peak resident sizes and block times measured with one item on one rank
(tiny disc scene; tests/test_estimate.py checks the memory side's shape). A process of the stack
takes about :data:`PROCESS_MIB`. One block of one item needs a transient :data:`CYCLE_MIB`
(Dang Van's point chunks, the contact solver's caches) plus, per grid point,
:data:`TRANSIENT_B_PER_POINT` + :data:`STEP_B_PER_POINT` × steps bytes (the steps' contact
fields and traction spectra) + :data:`STRESS_B_PER_POINT_LAYER_STEP` × chunk × steps (the
stress history of one chunk of depth layers, 48 of those bytes the history itself: the load
cycle streams the history through depth in chunks of
:func:`~micropit_hpc.mechanics.halfspace.history_chunk_layers` layers, at most
:data:`~micropit_hpc.mechanics.halfspace.STRESS_CHUNK_BYTES` per rank or one layer,
docs/performance.md "Streamed stresses"); the per-point part is split over the ranks of the
item. Every item a rank holds keeps :data:`ITEM_B_PER_POINT` + 32 × layers bytes per point (its
solvers, surfaces, damage); world rank 0 gathers every item's final maps. Refitted for the
streamed stresses on whole runs of the tiny disc scene at 15 layers and 20 steps; how close it
comes to the measured peaks, and the command that measures them, are in docs/performance.md
"Streamed stresses" (below about 64² the fixed CYCLE_MIB makes it an overestimate).
The time is an order of magnitude only (the contact solver's iterations and the adaptive splits
of a block vary with Λ and wear): about :data:`SECONDS_PER_POINT_LAYER_STEP` s per grid point,
layer + 4, and time step of each item's load cycle, fitted to two whole runs at the converged
default (adaptive blocks, implicit wear, the process length of 5 µm) on 2 ranks (docs/jobs.md,
"The estimate"); the items' times are spread over the groups longest first, as the dynamic
balance hands them out.

The time steps are each item's own (:func:`item_steps`): ``window.steps`` raised by the
kinematics, from the peak spacing of the patch's surfaces, as the run will choose them
(:func:`~micropit_hpc.cycle.cycle_steps`). They are known only once the plan is made and the
surfaces are drawn, so :func:`check` runs twice: before the plan with ``window.steps`` for every
item (a window too large for the node is refused before a surface is allocated), then with the
plan, whose estimate is the one printed."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from micropit_hpc.errors import MicropitError
from micropit_hpc.mechanics.halfspace import history_chunk_layers
from micropit_hpc.parallel.share import raise_agreed

PROCESS_MIB = 100.0
CYCLE_MIB = 180.0
TRANSIENT_B_PER_POINT = 1400.0
STEP_B_PER_POINT = 80.0
STRESS_B_PER_POINT_LAYER_STEP = 60.0
ITEM_B_PER_POINT = 1100.0
SECONDS_PER_POINT_LAYER_STEP = 3.9e-6
GIB = 2.0 ** 30


@dataclass(frozen=True)
class Estimate:
    """A run's estimate: ``item_block_s`` the mean of the items' block times, ``total_s`` the
    run's (the busiest group's blocks), ``steps`` the fewest and most time steps of the items'
    load cycles."""

    items: int
    groups: int
    items_per_group: int
    per_rank_bytes: float
    rank0_bytes: float
    node_bytes: float
    available_bytes: float | None
    item_block_s: float
    total_s: float
    steps: tuple[int, int]

    def line(self) -> str:
        avail = (f" of {self.available_bytes / GIB:.3g} GiB available"
                 if self.available_bytes else "")
        lo, hi = self.steps
        steps = f"{lo}" if lo == hi else f"{lo}–{hi}"
        return (f"estimate: {self.items} work items in {self.groups} groups (≤ "
                f"{self.items_per_group} per group): ~{self.per_rank_bytes / GIB:.3g} GiB per "
                f"rank (rank 0 {self.rank0_bytes / GIB:.3g} GiB), "
                f"~{self.node_bytes / GIB:.3g} GiB on this node{avail}; "
                f"~{_duration(self.item_block_s)} per item and block ({steps} time steps), "
                f"~{_duration(self.total_s)} in all (order of magnitude)")


def _duration(s: float) -> str:
    for unit, size in (("d", 86400), ("h", 3600), ("min", 60)):
        if s >= size:
            return f"{s / size:.2g} {unit}"
    return f"{s:.2g} s"


def available_memory() -> float | None:
    """Bytes this node can give the job: MemAvailable, capped by a cgroup limit."""
    best = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    best = float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(path).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 2 ** 60:
            best = float(text) if best is None else min(best, float(text))
    return best


def n_positions(scene, positions) -> int:
    if positions is not None:
        return len(positions)
    if scene.disc is not None:
        return len(scene.disc.slide_roll)
    p = scene.positions
    return p.count if p.kind == "count" else len(p.values)


def item_steps(plan) -> tuple[int, ...]:
    """The time steps of each work item's load cycle (in ``plan.items`` order), as its
    :class:`~micropit_hpc.study.ItemRun` chooses them: ``window.steps`` raised by the
    kinematics at the item's position, from the peak spacing of its patch's surfaces
    (:func:`~micropit_hpc.cycle.cycle_steps`; a roughness scale changes no spacing). Draws
    each patch's surfaces once (or reads them: measured maps)."""
    from micropit_hpc.cycle import counterface_spacing, cycle_steps
    from micropit_hpc.surfaces.bodies import body_surface

    grid, spacing, out = plan.window.grid, {}, []
    for it in plan.items:
        if it.patch not in spacing:
            surfaces = [body_surface(plan.scene, i, grid, it.patch) for i in (1, 2)]
            spacing[it.patch] = counterface_spacing(plan.scene, surfaces, grid.dx)
        out.append(cycle_steps(plan.scene, plan.conditions(it.position), spacing[it.patch])[0])
    return tuple(out)


def busiest_group(times: Sequence[float], groups: int) -> float:
    """The longest total of ``times`` in any of ``groups`` groups when each next-longest
    time goes to the group with the least so far (longest-processing-time first, as the
    dynamic balance hands out a block's items costliest first: Plan.queue_order)."""
    load = [0.0] * max(1, groups)
    for t in sorted(times, reverse=True):
        i = load.index(min(load))
        load[i] += t
    return max(load)


def estimate(scene, size: int, ranks_per_item: int, positions, blocks: int,
             local_ranks: int, steps: Sequence[int] | None = None) -> Estimate:
    """The estimate for ``scene`` on ``size`` ranks (``local_ranks`` of them on this node);
    ``steps``: each item's time steps (:func:`item_steps`; None: ``window.steps`` for all)."""
    w = scene.window
    points = w.nx * (w.ny or w.nx)
    layers = scene.stress.layers
    items = (n_positions(scene, positions) * len(scene.wear.k_lub)
             * len(scene.roughness_scale) * scene.patches)
    steps = (w.steps,) * items if steps is None else tuple(steps)
    if len(steps) != items:
        raise ValueError(f"estimate: {len(steps)} items' steps for {items} items")
    most = max(steps, default=w.steps)
    groups = max(1, size // max(1, ranks_per_item))
    per_group = math.ceil(items / groups)
    r = max(1, ranks_per_item)
    chunk = history_chunk_layers(layers, most, math.ceil(points / r))
    transient = CYCLE_MIB * 2 ** 20 + points * (
        TRANSIENT_B_PER_POINT + STEP_B_PER_POINT * most
        + STRESS_B_PER_POINT_LAYER_STEP * chunk * most) / r
    held = per_group * points * (ITEM_B_PER_POINT + 32.0 * layers) / r
    per_rank = PROCESS_MIB * 2 ** 20 + transient + held
    maps = items * points * 8.0 * 2 * (layers + 6)   # every item's final maps on rank 0
    rank0 = per_rank + maps
    node = per_rank * max(0, local_ranks - 1) + rank0
    times = [SECONDS_PER_POINT_LAYER_STEP * points * (layers + 4) * m / r for m in steps]
    mean = sum(times) / len(times) if times else 0.0
    return Estimate(items, groups, per_group, per_rank, rank0, node, available_memory(),
                    mean, busiest_group(times, groups) * blocks,
                    (min(steps, default=w.steps), most))


def npy_too_large(scene, available: float | None) -> str | None:
    """Why a measured ``.npy`` surface of the scene cannot be read (its header claims more
    than the available memory), or None; reads only the header."""
    import numpy as np

    for b, body in ((1, scene.body1), (2, scene.body2)):
        spec = body.surface
        if spec.kind != "file" or spec.file is None or not str(spec.file).endswith(".npy"):
            continue
        try:
            with open(spec.file, "rb") as fh:
                version = np.lib.format.read_magic(fh)
                shape, _fortran, dtype = np.lib.format._read_array_header(
                    fh, version, max_header_size=100000)
        except Exception:  # unreadable headers are the reader's to report
            continue
        need = float(np.prod(shape, dtype=float)) * dtype.itemsize
        if available is not None and need * 3 > available:   # the map, its copy, detrended
            return (f"{scene.source}: body{b}.surface.file = \"{spec.file}\": the file says it "
                    f"holds a {' × '.join(map(str, shape))} map of {dtype} "
                    f"({need / GIB:.3g} GiB); reading it needs about {3 * need / GIB:.3g} GiB, "
                    f"more than the {available / GIB:.3g} GiB available (a damaged header, or "
                    "crop the map first)")
    return None


def check(scene, comm, ranks_per_item: int, positions, blocks: int, log,
          ignore_memory: bool = False, plan=None) -> Estimate:
    """Refuse the run (collective error on every rank) when it does not fit this node's
    memory, unless ``ignore_memory``; with the ``plan``, the items' own time steps
    (:func:`item_steps`, rank 0) and the estimate printed (rank 0, by ``log``); without, every
    item at ``window.steps`` and nothing printed unless refused (the check before the plan:
    module docstring)."""
    local = _local_ranks(comm)
    problem, steps = None, None
    if comm.rank == 0 and plan is not None:
        try:            # rank 0 alone draws the surfaces: its error must reach every rank
            steps = item_steps(plan)
        except MicropitError as e:
            problem = str(e)
    est = estimate(scene, comm.size, ranks_per_item, positions, blocks, local, steps)
    if comm.rank == 0 and problem is None:
        if plan is not None:
            log(est.line())
        problem = npy_too_large(scene, est.available_bytes)
        if problem is None and est.available_bytes and est.node_bytes > est.available_bytes \
                and not ignore_memory:
            problem = (f"{scene.source}: the run needs about {est.node_bytes / GIB:.3g} GiB "
                       f"on this node ({est.per_rank_bytes / GIB:.3g} GiB per rank × {local} "
                       f"ranks, rank 0 {est.rank0_bytes / GIB:.3g} GiB with every item's maps), "
                       f"more than the {est.available_bytes / GIB:.3g} GiB available "
                       f"(window.n = {scene.window.nx}, stress.layers = {scene.stress.layers}, "
                       f"{est.items} work items): use fewer positions per job (--position), a "
                       f"smaller window, more ranks per item, more nodes, or "
                       "--ignore-memory-estimate if the estimate is wrong")
    raise_agreed(comm, problem)
    return est


def _local_ranks(comm) -> int:
    """Ranks on this node (the launcher's local size, else all of them)."""
    for var in ("OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_NTASKS_PER_NODE"):
        v = os.environ.get(var, "")
        if v.isdigit():
            return int(v)
    return comm.size
