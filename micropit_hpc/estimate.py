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
layer + 4, and time step, fitted to two whole runs at the converged default (adaptive blocks,
implicit wear, the process length of 5 µm) on 2 ranks (docs/jobs.md, "The estimate")."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from micropit_hpc.mechanics.halfspace import history_chunk_layers
from micropit_hpc.parallel.share import raise_agreed

PROCESS_MIB = 100.0
CYCLE_MIB = 180.0
TRANSIENT_B_PER_POINT = 1400.0
STEP_B_PER_POINT = 80.0
STRESS_B_PER_POINT_LAYER_STEP = 60.0
ITEM_B_PER_POINT = 1100.0
SECONDS_PER_POINT_LAYER_STEP = 4.5e-6
GIB = 2.0 ** 30


@dataclass(frozen=True)
class Estimate:
    items: int
    groups: int
    items_per_group: int
    per_rank_bytes: float
    rank0_bytes: float
    node_bytes: float
    available_bytes: float | None
    item_block_s: float
    total_s: float

    def line(self) -> str:
        avail = (f" of {self.available_bytes / GIB:.3g} GiB available"
                 if self.available_bytes else "")
        return (f"estimate: {self.items} work items in {self.groups} groups (≤ "
                f"{self.items_per_group} per group): ~{self.per_rank_bytes / GIB:.3g} GiB per "
                f"rank (rank 0 {self.rank0_bytes / GIB:.3g} GiB), "
                f"~{self.node_bytes / GIB:.3g} GiB on this node{avail}; "
                f"~{_duration(self.item_block_s)} per item and block, "
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


def estimate(scene, size: int, ranks_per_item: int, positions, blocks: int,
             local_ranks: int) -> Estimate:
    """The estimate for ``scene`` on ``size`` ranks (``local_ranks`` of them on this node)."""
    w = scene.window
    points = w.nx * (w.ny or w.nx)
    layers = scene.stress.layers
    items = (n_positions(scene, positions) * len(scene.wear.k_lub)
             * len(scene.roughness_scale) * scene.patches)
    groups = max(1, size // max(1, ranks_per_item))
    per_group = math.ceil(items / groups)
    r = max(1, ranks_per_item)
    chunk = history_chunk_layers(layers, w.steps, math.ceil(points / r))
    transient = CYCLE_MIB * 2 ** 20 + points * (
        TRANSIENT_B_PER_POINT + STEP_B_PER_POINT * w.steps
        + STRESS_B_PER_POINT_LAYER_STEP * chunk * w.steps) / r
    held = per_group * points * (ITEM_B_PER_POINT + 32.0 * layers) / r
    per_rank = PROCESS_MIB * 2 ** 20 + transient + held
    maps = items * points * 8.0 * 2 * (layers + 6)   # every item's final maps on rank 0
    rank0 = per_rank + maps
    node = per_rank * max(0, local_ranks - 1) + rank0
    block_s = SECONDS_PER_POINT_LAYER_STEP * points * (layers + 4) * w.steps / r
    return Estimate(items, groups, per_group, per_rank, rank0, node, available_memory(),
                    block_s, block_s * per_group * blocks)


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
          ignore_memory: bool = False) -> Estimate:
    """Print the estimate (rank 0) and refuse the run (collective error on every rank) when
    it does not fit this node's memory, unless ``ignore_memory``."""
    local = _local_ranks(comm)
    est = estimate(scene, comm.size, ranks_per_item, positions, blocks, local)
    problem = None
    if comm.rank == 0:
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
