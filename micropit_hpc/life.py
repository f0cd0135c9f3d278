"""The life simulation at one contact point: blocks of ΔN load cycles (docs/model.md §5).

Per block: the surfaces the contact sees from the state of both bodies (:func:`contact_surfaces`)
→ one load-cycle evaluation on them (:meth:`PositionCycle.evaluate
<micropit_hpc.cycle.PositionCycle.evaluate>`, docs/model.md §4): damage per cycle d(z, x, y) (Dang
Van, S–N line, cycle counting) and wear per cycle Δh(x, y) (Archard) of each body → Miner's rule
D += ΔN d, wear removed and the damage columns moved up, micropits where D ≥ 1 → the state of
the next block. The settings are the scene's ``[life]`` table (:class:`~micropit_hpc.scene.
LifeSpec`), passed as it is; the load cycle's own (fatigue, wear) are the cycle's.

**Adaptive blocks [choice]** (docs/model.md §5): a block is split into sub-blocks, each evaluated on
the surfaces the previous one left, when in one go it would change the shape of a body's surface
by more than ``max_wear_fraction`` of its initial R_q anywhere, or raise the largest damage of
the intact material by more than ``max_damage_step``, or newly pit more than ``max_pit_step``
of the window's columns. The sub-block is then cut to the wear limit, and
halved while the damage rise or the new pits are too many, but never below ΔN/``max_splits``.
ΔN stays the checkpoint and report interval.

The pit limit resolves the cascade: a pit unloads its columns onto its neighbours, whose
damage rate then jumps, so the pits grow one generation per sub-block. The damage limit leaves
out the points that fail within the sub-block, so without the pit limit a block without wear
took 1–2 sub-blocks and A_p depended on their length (measured in docs/life.md, "Resolving
the running-in").

The shape change of a sub-block is its wear depth less the mean depth, over the intact columns
(:func:`shape_change`). A uniform removal moves the surface and its damage columns down
together and changes neither the contact nor the stresses, so it needs no split; the part of
the wear that differs from place to place is what runs the surface in, and its rate changes as
it does. Stopping the split early over-predicts A_p, and the coarse steps leave a texture that
shortens λ_c and runs A_p away after a few M cycles (docs/life.md, "Resolving the running-in",
has the measurements against the number of sub-blocks).

**Time integration [decision]** (``integration``): ``"adaptive"`` (default) is the split
above; ``"paper"`` is the paper's own scheme (Morales-Espejel, Rycerz & Kadiric 2018 §2.1):
fixed blocks of ΔN, one load-cycle evaluation per block on the block's starting surfaces,
damage and wear both applied over the whole block, the damage columns moved up by the worn
depth, then the pit check. In that scheme the wear–fatigue competition depends on ΔN: a point
whose life is shorter than the time wear needs to reach it still escapes if the block's wear
removes it before the check (docs/life.md, "Two time integrations").

**Wear integration [choice]** (``wear_integration``, :mod:`micropit_hpc.wear`): the wear of a
sub-block is ``relaxed`` (default: the stiff solid-contact part integrated as the linearised
pressure relief it causes) or ``explicit`` (n Δh_i, docs/model.md §4.6 as written). The split's
wear limit applies to the integrated depth.

Units: SI (metres, pascals, cycles). No I/O. **Collective** over the work item's group (the
ranks of ``cycle.slab.comm``): :func:`run_block` (the load-cycle evaluation: contact and
stresses on each rank's slab rows, docs/hpc.md §2; the group-wide maxima and sums of the
record), :func:`apply_cycles` (the pits found on each rank's rows gathered to every rank,
:meth:`Slab.allgather_rows <micropit_hpc.parallel.slab.Slab.allgather_rows>`) and
:func:`sub_block_cycles` (the damage rise and new pits over the whole window, :meth:`Slab.max
<micropit_hpc.parallel.slab.Slab.max>` and ``allgather_rows``), which every rank of the group
calls with the same arguments; on a one-rank slab these reductions are the local values. The
other functions are local to the rank.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter

from micropit_hpc.cycle import CycleResult, PositionCycle
from micropit_hpc.parallel.petsc import event
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.pits import detach, shift_columns
from micropit_hpc.scene import INTEGRATIONS, LifeSpec
from micropit_hpc.spectral import Grid
from micropit_hpc.state import BlockRecord, BodyState, LifeState
from micropit_hpc.surfaces import Topography
from micropit_hpc.wear import WearRate

__all__ = ["INTEGRATIONS", "BlockRecord", "BodyState", "BodyStep", "LifeState", "apply_cycles",
           "contact_surfaces", "deep_damage_ratio", "initial_state", "rms_slope", "run_block",
           "shape_change", "sub_block_cycles"]


@dataclass(frozen=True)
class BodyStep:
    """What :func:`apply_cycles` did to one body: the shape change its wear made
    (:func:`shape_change`), the columns it newly pitted and how many of those came from
    N < n_min (on the whole window), and the damage it added in all and from N < n_min (on
    this rank's rows)."""

    shape_change: float
    new_pits: int
    new_low_pits: int
    damage_added: float
    low_damage_added: float


def initial_state(cycle: PositionCycle) -> LifeState:
    """Fresh bodies on the cycle's surfaces (:meth:`~micropit_hpc.state.BodyState.fresh`): no
    damage, no wear, no pits. Layered fields hold this rank's slab rows
    (:attr:`PositionCycle.slab`), the 2-D fields the whole window."""
    bodies = tuple(BodyState.fresh(s.heights, cycle.slab.local_shape, s.rq)
                   for s in cycle.surfaces)
    return LifeState(bodies=bodies)


#: Width (grid cells) of the Gaussian over which a pitted column takes the wear around it.
PIT_FILL_CELLS = 2.0


def _around_pits(bs: BodyState) -> np.ndarray:
    """The surface the contact sees with unloaded pits: each pitted column at the height it
    had before its pit (heights + pit depth), lowered by the wear it has missed since.

    A pitted column carries no load and so no longer wears, while the intact surface around it
    does; left at its pre-pit height it would stand up as a spike once the surface around it
    has worn (a micron after a few M cycles at k_lub = 1e-11 s), and take most of the load of
    the contact solve that the unloading then removes. The wear it missed is the local mean
    wear of the intact columns around it (a Gaussian of 2 cells, periodic, normalised over the
    intact columns; the mean of all intact columns inside a pit too large for it) less its own.
    Without wear this is the pre-pit surface exactly: a pitted asperity keeps its shape and
    the surface around it its load path (docs/model.md §4.5, docs/life.md)."""
    h = bs.heights + bs.pit_depth
    if not bs.pitted.any() or bs.pitted.all() or not bs.wear.any():
        return h
    intact = (~bs.pitted).astype(float)
    weight = gaussian_filter(intact, PIT_FILL_CELLS, mode="wrap")
    local = gaussian_filter(bs.wear * intact, PIT_FILL_CELLS, mode="wrap")
    around = np.where(weight > 1e-3, local / np.maximum(weight, 1e-300),
                      bs.wear[~bs.pitted].mean())
    return np.where(bs.pitted, h - np.maximum(around - bs.wear, 0.0), h)


def contact_surfaces(state: LifeState, grid: Grid, pit_contact: str
                     ) -> tuple[tuple[Topography, Topography],
                                tuple[np.ndarray, np.ndarray] | None]:
    """The surfaces the contact sees in ``state`` and the pitted columns that carry no load,
    for :meth:`PositionCycle.evaluate`, by ``life.pit_contact``: ``"unloaded"``, the surface
    around the pits (:func:`_around_pits`) and each body's pits; ``"geometric"``, the heights
    as they are (pits and all) and no unloaded columns (None)."""
    if pit_contact == "unloaded":   # the surface around the pits; pits carry nothing
        tops = tuple(Topography(_around_pits(b), grid.dx, grid.dy, "evolved")
                     for b in state.bodies)
        return tops, tuple(b.pitted for b in state.bodies)
    return tuple(Topography(b.heights, grid.dx, grid.dy, "evolved") for b in state.bodies), None


def apply_cycles(state: LifeState, result: CycleResult, n: float, z: np.ndarray, slab: Slab,
                 wear_integration: str) -> list[BodyStep]:
    """Advance both bodies by ``n`` load cycles at the rates of ``result`` (in place):
    Miner's rule, wear (heights down, damage columns up; ``life.wear_integration``), then
    micropits (docs/model.md §4.4–§4.6). ``slab``: the rows of the damage this rank holds
    (:attr:`PositionCycle.slab`); the pits found on each slab are shared so that every rank
    keeps the whole surface. Collective. Returns what it did to each body (:class:`BodyStep`)."""
    done = []
    rows = slab.rows
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        added = n * bc.damage_rate
        low = None if bc.damage_low is None else n * bc.damage_low
        bs.damage += added
        # the most damaged point of each column decides where its pit's damage came from
        if low is None:
            low_col = np.zeros(bs.damage.shape[1:], bool)
        else:
            top = np.argmax(bs.damage, axis=0)[None]
            low_col = 2.0 * np.take_along_axis(low, top, 0)[0] > bs.damage.max(axis=0)
        dh = bc.wear.depth(n, wear_integration)
        worn = shape_change(dh, ~bs.pitted)
        if dh.any():
            bs.heights -= dh
            bs.wear += dh
            bs.damage = shift_columns(bs.damage, z, dh[rows])
        damage, depth, new = detach(bs.damage, z)
        bs.damage = damage
        depth, new = slab.allgather_rows(depth), slab.allgather_rows(new)
        low_col = slab.allgather_rows(low_col)
        fresh = new & ~bs.pitted
        if new.any():
            bs.heights -= depth
            bs.pit_depth += depth
            bs.pitted |= new
        done.append(BodyStep(worn, int(fresh.sum()), int((fresh & low_col).sum()),
                             float(added.sum()), 0.0 if low is None else float(low.sum())))
    state.cycles += n
    return done


def _damage_rise(state: LifeState, result: CycleResult, n: float, slab: Slab) -> float:
    """Rise of the largest damage of the intact material over ``n`` cycles (points that reach
    1 pit and leave the intact material), over the whole group of ``slab``. Collective."""
    rise = -math.inf
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        after = bs.damage + n * bc.damage_rate
        intact = after < 1.0
        top = slab.max(float(after[intact].max()) if intact.any() else 0.0)
        rise = max(rise, top - slab.max(float(bs.damage.max())))
    return rise


def _new_pits(state: LifeState, result: CycleResult, n: float, slab: Slab) -> float:
    """The largest share of a body's window columns that ``n`` cycles would newly pit (an
    intact column some layer of which reaches D = 1), over the whole window (the rows of
    every rank of ``slab``). Collective."""
    share = 0.0
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        failing = slab.allgather_rows(((bs.damage + n * bc.damage_rate) >= 1.0).any(axis=0))
        share = max(share, float((failing & ~bs.pitted).mean()))
    return share


def shape_change(depth: np.ndarray, intact: np.ndarray) -> float:
    """The largest change of a surface's shape that a wear depth map makes: max |Δh − ⟨Δh⟩|
    over the ``intact`` columns (a uniform removal changes nothing the contact sees; pitted
    columns follow the wear around them, :func:`_around_pits`)."""
    d = depth[intact]
    return float(np.abs(d - d.mean()).max()) if d.size else 0.0


def _wear_limited(wear: WearRate, limit: float, n: float, integration: str,
                  intact: np.ndarray) -> float:
    """The largest m ≤ n whose integrated wear changes the shape of the surface by at most
    ``limit`` (:func:`shape_change`; bisection to 1e-6 relative: the change grows with the
    cycles for any rate map that is not uniform)."""
    def change(m: float) -> float:
        return shape_change(wear.depth(m, integration), intact)

    if change(n) <= limit:
        return n
    lo, hi = 0.0, n
    while hi - lo > 1e-6 * hi:
        mid = 0.5 * (lo + hi)
        if change(mid) <= limit:
            lo = mid
        else:
            hi = mid
    return lo


def sub_block_cycles(state: LifeState, result: CycleResult, left: float, life: LifeSpec,
                     slab: Slab) -> float:
    """Cycles of the next sub-block: the adaptive split (module docstring) by the limits of
    ``life`` (``scene.life``), over the whole group of ``slab`` (collective); the whole of
    ``left`` in the paper's scheme (``integration = "paper"``)."""
    if life.integration == "paper":
        return left
    floor = life.block / life.max_splits
    n = left
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        if bs.rq0 > 0:
            n = min(n, _wear_limited(bc.wear, life.max_wear_fraction * bs.rq0, n,
                                     life.wear_integration, ~bs.pitted))
    n = max(n, min(floor, left))
    while n > floor and (_damage_rise(state, result, n, slab) > life.max_damage_step
                         or _new_pits(state, result, n, slab) > life.max_pit_step):
        n = max(0.5 * n, floor)
    if left - n <= 1e-9 * life.block:
        n = left
    return min(n, left)


#: A column counts in :func:`deep_damage_ratio` when it gathers at least this damage per block:
#: one that could pit within ten blocks (the valleys between contact spots gather their little
#: damage below the surface, from their neighbours' loads, and would otherwise always count).
DEEP_SIGNIFICANT = 0.1


def deep_damage_ratio(rate: np.ndarray, significant: float = 0.0,
                      intact: np.ndarray | None = None) -> float:
    """The largest ratio, over the columns, of the deepest layer's damage rate to the column's
    largest: how much damage the layers leave below them. Only intact columns (``intact``,
    default all) whose largest rate is at least ``significant`` count (0 when none does): a
    column that gathers no damage worth the name (the smooth macro cycle alone, whose Hertz
    stress peaks far below the layers) says nothing about whether the layers reach deep
    enough, and under an unloaded pit the neighbours' load peaks below the pit floor, which
    is the pit's growth (reported as ``pit_depth_max``), not the layers' reach."""
    top = rate.max(axis=0)
    use = (top > 0) & (top >= significant)
    if intact is not None:
        use &= intact
    ratio = np.divide(rate[-1], top, out=np.zeros_like(top), where=use)
    return float(ratio.max()) if ratio.size else 0.0


def rms_slope(heights: np.ndarray, dx: float) -> float:
    """Δq: the RMS slope along x (axis 0) of a periodic height map, by forward differences
    (ISO 4287's Δq of the x-profiles, on the grid)."""
    return float(np.sqrt(np.mean(((np.roll(heights, -1, axis=0) - heights) / dx) ** 2)))


def run_block(cycle: PositionCycle, state: LifeState, life: LifeSpec,
              cycles: float | None = None,
              on_progress: Callable[..., None] | None = None) -> BlockRecord:
    """One block of ΔN = ``life.block`` load cycles (or ``cycles``) with the settings of
    ``life`` (``scene.life``): split adaptively (``integration = "adaptive"``) or in one step
    on the block's starting surfaces (the paper's scheme, ``"paper"``); returns its record.
    Collective over the cycle's group (every rank returns the same record).
    ``on_progress(cycles_done, block_cycles, sub_block, step, steps)``: called after every
    time step of every sub-block's load cycle (progress reports; changes nothing)."""
    t0 = time.perf_counter()
    slab = cycle.slab
    left = life.block if cycles is None else cycles
    subs, phi_acc, plastic_acc, n_done, wear_step, pit_step = 0, 0.0, 0.0, 0.0, 0.0, 0.0
    new_pits, low_pits = [0, 0], [0, 0]
    added, low_added, deep = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
    result, warm = None, {}
    total = left
    while left > 0:
        step = None if on_progress is None else (
            lambda j, d=n_done, s=subs + 1: on_progress(d, total, s, j, cycle.steps))
        surfaces, pits = contact_surfaces(state, cycle.grid, life.pit_contact)
        result = cycle.evaluate(surfaces, pits, warm, step)
        n = sub_block_cycles(state, result, left, life, slab)
        for i, bc in enumerate(result.bodies):
            intact = ~state.bodies[i].pitted[slab.rows]
            deep[i] = max(deep[i], slab.max(deep_damage_ratio(
                bc.damage_rate, DEEP_SIGNIFICANT / life.block, intact)))
        with event("apply_cycles"):
            steps = apply_cycles(state, result, n, cycle.z, slab, life.wear_integration)
        for i, (bs, st) in enumerate(zip(state.bodies, steps, strict=True)):
            if bs.rq0 > 0:
                wear_step = max(wear_step, st.shape_change / bs.rq0)
            pit_step = max(pit_step, st.new_pits / bs.pitted.size)
            new_pits[i] += st.new_pits
            low_pits[i] += st.new_low_pits
            added[i] += st.damage_added
            low_added[i] += st.low_damage_added
        phi_acc += n * result.phi
        plastic_acc += n * result.plastic_share
        n_done += n
        left -= n
        subs += 1
    state.block += 1
    b = state.bodies
    added = [slab.sum(a) for a in added]
    low_added = [slab.sum(a) for a in low_added]
    rec = BlockRecord(
        block=state.block, cycles=state.cycles, sub_blocks=subs, phi=phi_acc / n_done,
        wall_s=time.perf_counter() - t0, Ap=(b[0].Ap, b[1].Ap),
        max_damage=(slab.max(b[0].damage.max()), slab.max(b[1].damage.max())),
        wear_mean=(float(b[0].wear.mean()), float(b[1].wear.mean())),
        wear_max=(float(b[0].wear.max()), float(b[1].wear.max())),
        Rq=(b[0].rq, b[1].rq),
        n_micro=(result.bodies[0].n_micro, result.bodies[1].n_micro), wear_step=wear_step,
        pit_step=pit_step,
        low_cycle_damage=tuple(lo / a if a > 0 else 0.0 for lo, a in zip(low_added, added,
                                                                          strict=True)),
        low_cycle_pits=tuple(lo / n if n else 0.0 for lo, n in zip(low_pits, new_pits,
                                                                    strict=True)),
        plastic_share=plastic_acc / n_done, deep_damage=(deep[0], deep[1]),
        slope=tuple(rms_slope(bs.heights + bs.pit_depth, cycle.grid.dx) for bs in b),
        pit_depth_max=tuple(float(bs.pit_depth.max()) for bs in b))
    return rec
