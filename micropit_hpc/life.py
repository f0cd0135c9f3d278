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
halved while the damage rise or the new pits are too many, but never below the smallest
sub-block (:func:`smallest_sub_block`: ``min_sub_block``, the same for every ΔN, unless
ΔN/``max_splits`` is larger). ΔN stays the checkpoint and report interval.

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

**Wear integration [decision]** (``wear_integration``): in the adaptive integration the wear
of a sub-block is ``implicit`` by default (:func:`implicit_sub_block`,
:mod:`micropit_hpc.implicit_wear`): backward-Euler steps whose worn depth is consistent with
the contact solved on the worn surfaces, with their own accuracy control inside the sub-block
(contact-only load cycles; the damage stays on the sub-block's full evaluation), and the
sub-block ends once its wear has changed a surface's shape by ``max_wear_fraction`` × R_q.
``relaxed`` (the stiff solid-contact part relieved by one grid cell's compliance, so its
depth follows the cell size) and ``explicit`` (n Δh_i) stay as documented, not converged,
options; the split's wear limit then applies to their integrated depth. The paper's
integration always wears explicitly (its literal numerics).

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
from micropit_hpc.implicit_wear import SpectralRelief, backward_euler, next_length
from micropit_hpc.lubrication.dry import ContactError
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


def _around(values: np.ndarray, pitted: np.ndarray) -> np.ndarray:
    """``values`` with each pitted column replaced by the local mean of the intact columns
    around it (a Gaussian of :data:`PIT_FILL_CELLS` cells, periodic, normalised over the intact
    columns; the mean of all intact columns inside a pit too large for it)."""
    if not pitted.any() or pitted.all():
        return values
    intact = (~pitted).astype(float)
    weight = gaussian_filter(intact, PIT_FILL_CELLS, mode="wrap")
    local = gaussian_filter(values * intact, PIT_FILL_CELLS, mode="wrap")
    around = np.where(weight > 1e-3, local / np.maximum(weight, 1e-300),
                      values[~pitted].mean())
    return np.where(pitted, around, values)


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
    return h - np.maximum(_around(bs.wear, bs.pitted) - bs.wear, 0.0)


def contact_surfaces(state: LifeState, grid: Grid, pit_contact: str
                     ) -> tuple[tuple[Topography, Topography],
                                tuple[np.ndarray, np.ndarray] | None]:
    """The surfaces the contact sees in ``state`` and the pitted columns that carry no load,
    for :meth:`PositionCycle.evaluate`, by ``life.pit_contact``: ``"unloaded"`` and
    ``"open"``, the surface around the pits (:func:`_around_pits`) and each body's pits
    (``"open"``: held at p = 0 inside the contact solve, :meth:`PositionCycle.solve_step`);
    ``"geometric"``, the heights as they are (pits and all) and no unloaded columns (None)."""
    if pit_contact in ("unloaded", "open"):     # the surface around the pits; pits carry nothing
        tops = tuple(Topography(_around_pits(b), grid.dx, grid.dy, "evolved")
                     for b in state.bodies)
        return tops, tuple(b.pitted for b in state.bodies)
    return tuple(Topography(b.heights, grid.dx, grid.dy, "evolved") for b in state.bodies), None


def apply_cycles(state: LifeState, result: CycleResult, n: float, z: np.ndarray, slab: Slab,
                 wear_integration: str,
                 depths: tuple[np.ndarray, np.ndarray] | None = None) -> list[BodyStep]:
    """Advance both bodies by ``n`` load cycles at the rates of ``result`` (in place):
    Miner's rule, wear (heights down, damage columns up; ``life.wear_integration``: the
    sub-block's worn ``depths`` where the implicit update solved them, else the rates of
    ``result`` integrated by :meth:`WearRate.depth <micropit_hpc.wear.WearRate.depth>`), then
    micropits (docs/model.md §4.4–§4.6). ``slab``: the rows of the damage this rank holds
    (:attr:`PositionCycle.slab`); the pits found on each slab are shared so that every rank
    keeps the whole surface. Collective. Returns what it did to each body (:class:`BodyStep`)."""
    done = []
    rows = slab.rows
    for i, (bs, bc) in enumerate(zip(state.bodies, result.bodies, strict=True)):
        added = n * bc.damage_rate
        low = None if bc.damage_low is None else n * bc.damage_low
        bs.damage += added
        # the most damaged point of each column decides where its pit's damage came from
        if low is None:
            low_col = np.zeros(bs.damage.shape[1:], bool)
        else:
            top = np.argmax(bs.damage, axis=0)[None]
            low_col = 2.0 * np.take_along_axis(low, top, 0)[0] > bs.damage.max(axis=0)
        if depths is None and wear_integration == "implicit":
            raise ValueError("implicit wear: give the solved depths (implicit_sub_block); "
                             "a rate alone is integrated only as 'relaxed' or 'explicit'")
        dh = bc.wear.depth(n, wear_integration) if depths is None else depths[i]
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


def smallest_sub_block(life: LifeSpec) -> float:
    """The smallest sub-block [cycles] of the adaptive split (module docstring): the scene's
    ``life.min_sub_block_M`` [choice], or ΔN/``life.max_splits`` where that is larger (a
    bound on the sub-blocks per block)."""
    return max(life.min_sub_block, life.block / life.max_splits)


def sub_block_cycles(state: LifeState, result: CycleResult, left: float, life: LifeSpec,
                     slab: Slab) -> float:
    """Cycles of the next sub-block: the adaptive split (module docstring) by the limits of
    ``life`` (``scene.life``), over the whole group of ``slab`` (collective); the whole of
    ``left`` in the paper's scheme (``integration = "paper"``)."""
    if life.integration == "paper":
        return left
    floor = smallest_sub_block(life)
    n = left
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        if bs.rq0 > 0 and life.wear_integration != "implicit":
            n = min(n, _wear_limited(bc.wear, life.max_wear_fraction * bs.rq0, n,
                                     life.wear_integration, ~bs.pitted))
    n = max(n, min(floor, left))
    while n > floor and (_damage_rise(state, result, n, slab) > life.max_damage_step
                         or _new_pits(state, result, n, slab) > life.max_pit_step):
        n = max(0.5 * n, floor)
    if left - n <= 1e-9 * life.block:
        n = left
    return min(n, left)


def _worn(surfaces: tuple[Topography, Topography], state: LifeState,
          depths: tuple[np.ndarray, np.ndarray]) -> tuple[Topography, Topography]:
    """``surfaces`` (:func:`contact_surfaces`) lowered by a trial wear ``depths``; a pitted
    column follows the wear of the intact columns around it, as :func:`_around_pits` lets it."""
    return tuple(Topography(s.heights - _around(w, b.pitted), s.dx, s.dy, "worn")
                 for s, b, w in zip(surfaces, state.bodies, depths, strict=True))


@dataclass(frozen=True)
class WearSteps:
    """The implicit wear of one sub-block (:func:`implicit_sub_block`): its cycles, the worn
    depth of each body over them [m], the next wear step the controller proposes, the
    contact-only load cycles spent, the largest residual of an accepted step over R_q
    (above ``life.wear_tol`` where a step at the smallest length still did not converge), the
    step length the block's steps stay below, the cycles integrated by the relaxed fallback,
    the last accepted step (its cycles and worn depths: the next step's first iterate), and
    the solves thrown away (not converged, or cut after their solve by the accuracy or the
    shape limit) with the contact-only load cycles they took, part of ``contact_cycles``."""

    cycles: float
    depth: tuple[np.ndarray, np.ndarray]
    proposal: float
    contact_cycles: int
    residual: float
    cap: float = math.inf
    fallback: float = 0.0
    previous: tuple | None = None
    thrown: tuple[int, int] = (0, 0)


#: The contact-only load cycles one sub-block's implicit wear may spend, in units of
#: ``life.wear_max_iter``; past them the rest of the sub-block is integrated by the relaxed
#: update from the last solved rates, and the block is flagged (``wear_unresolved``).
WEAR_BUDGET = 8

#: The smallest wear step, as a share of the smallest sub-block (:func:`smallest_sub_block`): a step
#: that does not converge is halved down to it, and accepted there.
MIN_WEAR_STEP = 1.0 / 16.0

#: After a step whose solve did not converge the block's steps stay below three quarters of
#: it; a step whose solve took more than a third of ``life.wear_max_iter`` contact cycles caps
#: them at its own length (longer steps cost more cycles per cycle integrated), and one that
#: took fewer than a sixth lets the cap grow by this factor (a cap for the rest of the block
#: held the running-in's short steps long after the surfaces had run in; docs/life.md).
CAP_GROWTH = 1.25


#: Whether a wear step that its first iterate (a solved depth scaled to the step) shows past the
#: sub-block's shape limit is cut before it is solved (:func:`implicit_sub_block`). False: every
#: step is solved at the controller's length and cut only after its solve, which then is thrown
#: away (docs/life.md, "Steps cut at the shape limit": the contact cycles this saves).
SHAPE_FORECAST = True


def implicit_sub_block(cycle: PositionCycle, state: LifeState, result: CycleResult,
                       surfaces: tuple[Topography, Topography],
                       pits: tuple[np.ndarray, np.ndarray] | None, warm: dict, n: float,
                       proposal: float | None, life: LifeSpec,
                       cap: float = math.inf, previous: tuple | None = None) -> WearSteps:
    """The implicit wear of the next sub-block (``life.wear_integration = "implicit"``,
    :mod:`micropit_hpc.implicit_wear`) of at most ``n`` cycles (the damage and pit limits,
    :func:`sub_block_cycles`): backward-Euler steps over contact-only load cycles on the worn
    ``surfaces``, each solved to ``life.wear_tol`` × R_q (R_q: the smallest initial R_q of the
    rough bodies). The first step is the controller's ``proposal`` (None: from the starting
    rates, a local error of (n/2)·|Δh(0)| at most); a step is halved while its solve does not
    converge (and later steps, this sub-block's and, through ``cap``, the block's next ones,
    stay below three quarters of it), and cut while its local error exceeds
    ``life.wear_accuracy`` × R_q, down to :data:`MIN_WEAR_STEP` of the smallest sub-block
    (:func:`smallest_sub_block`), where it is accepted. The sub-block ends early, after at
    least the smallest sub-block, once
    its wear has changed a surface's shape by ``life.max_wear_fraction`` × R_q
    (:func:`shape_change`): the damage of the next sub-block is then evaluated on the run-in
    surfaces. Each solve is preconditioned by the half-spaces' elastic relief
    (:class:`~micropit_hpc.implicit_wear.SpectralRelief`) and starts from the ``previous``
    accepted step's worn depth scaled to its length (the last sub-block's, None: the explicit
    step), or, where a converged step was cut shorter (by the accuracy or the shape limit),
    from that step's worn depth scaled to the shorter length. Collective (the contact)."""
    bodies = state.bodies
    intact = [~b.pitted for b in bodies]
    rq = min((b.rq0 for b in bodies if b.rq0 > 0), default=0.0)
    rates0 = tuple(bc.wear for bc in result.bodies)
    if rq == 0.0 or not any(r.rate.any() for r in rates0):
        # smooth bodies (nothing to relieve) or no wear: the explicit rate is exact
        return WearSteps(n, tuple(n * r.rate for r in rates0), n, 0, 0.0, cap)
    tol, accuracy = life.wear_tol * rq, life.wear_accuracy * rq
    floor = min(smallest_sub_block(life), n)
    smallest = MIN_WEAR_STEP * floor
    if proposal is None:
        top = max(shape_change(r.rate, keep) for r, keep in zip(rates0, intact, strict=True))
        proposal = 2.0 * accuracy / top if top > 0 else n
    depth = tuple(np.zeros_like(r.rate) for r in rates0)
    done, spent, worst, h, now = 0.0, 0, 0.0, max(proposal, smallest), rates0

    def shape(maps) -> float:
        return max(shape_change(d, keep) / b.rq0 for d, keep, b
                   in zip(maps, intact, bodies, strict=True) if b.rq0 > 0)

    limit, last, fallback = life.max_wear_fraction, False, 0.0
    retry = None        # a converged step cut shorter: its depth, scaled, starts the shorter one
    thrown = (0, 0)     # solves not accepted, and their contact-only cycles

    def landing(m: float, change: float, before: float, done: float) -> float | None:
        """The length that lands a step of ``m`` cycles, whose shape change is ``change``, at
        0.95 of the limit (but not before the floor; linear in the step), or None where
        that is not shorter than m."""
        cut = max(floor - done, 0.95 * m * (limit - before) / max(change - before, 1e-300))
        return max(cut, smallest) if cut < (1 - 1e-6) * m else None

    hs = cycle.half_spaces
    relief = SpectralRelief(hs.stiffness, hs.self_compliance, cycle.grid.shape)
    while n - done > 1e-9 * n:
        if spent >= WEAR_BUDGET * life.wear_max_iter:
            fallback = n - done
            depth = tuple(d + r.depth(fallback, "relaxed")
                          for d, r in zip(depth, now, strict=True))
            done = n
            break
        m = min(h, n - done)
        base, before = depth, shape(depth)
        start = previous if retry is None else retry
        if (SHAPE_FORECAST and start is not None and not last and m > smallest
                and done + m > floor * (1 + 1e-9)):
            # the first iterate, scaled to m, foretells the step's shape change (it is a
            # solved depth at another length): a step it shows past the shape limit is cut
            # before it is solved, as a solved one would be
            ahead = shape(tuple(d + (m / start[0]) * w
                                for d, w in zip(depth, start[1], strict=True)))
            cut = landing(m, ahead, before, done) if ahead > limit * (1 + 1e-9) else None
            if cut is not None:
                m, last = cut, True

        def rates(w, base=base):
            return cycle.wear_rates(_worn(surfaces, state, tuple(
                d + x for d, x in zip(base, w, strict=True))), pits, warm)

        with event("implicit_wear"):
            guess = None if start is None else tuple((m / start[0]) * w for w in start[1])
            sol = backward_euler(rates, now, m, tol, max_iter=life.wear_max_iter,
                                 errors=(ContactError,), relief=relief, guess=guess,
                                 invariant=True)
        spent += sol.iterations
        thrown = (thrown[0] + 1, thrown[1] + sol.iterations)    # until it is accepted below
        err = max(sol.error(intact))
        if m > smallest and not sol.converged:
            cap = min(cap, 0.75 * m)
            h = max(0.5 * m, smallest)
            continue
        if m > smallest and err > accuracy:
            h = max(next_length(m, err, accuracy, grow=1.0), smallest)
            retry = (m, sol.depth)
            continue
        after = tuple(d + x for d, x in zip(depth, sol.depth, strict=True))
        grown = shape(after)
        if done + m > floor * (1 + 1e-9) and grown > limit * (1 + 1e-9) and m > smallest:
            # end the sub-block at the shape limit (but not before the floor): a shorter step
            cut = landing(m, grown, before, done)
            if cut is not None:
                h, last, retry = cut, True, (m, sol.depth)
                continue
        if not sol.converged or 3 * sol.iterations > life.wear_max_iter:
            cap = min(cap, m)                   # (not converged: accepted at the smallest step)
        elif 6 * sol.iterations < life.wear_max_iter:
            cap *= CAP_GROWTH
        worst = max(worst, sol.residual / rq)
        depth, now, done = after, sol.rate_end, done + m
        thrown = (thrown[0] - 1, thrown[1] - sol.iterations)
        previous, retry = (m, sol.depth), None
        h = min(next_length(m, err, accuracy), max(cap, m))
        if done >= floor * (1 - 1e-9) and (last or grown >= limit):
            break
    return WearSteps(done, depth, h, spent, worst, cap, fallback, previous, thrown)


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
    pit_load_acc = 0.0
    new_pits, low_pits = [0, 0], [0, 0]
    added, low_added, deep = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
    result, warm = None, {}
    total = left
    wear_mode = "explicit" if life.integration == "paper" else life.wear_integration
    implicit = wear_mode == "implicit" and cycle.k_lub > 0
    if wear_mode == "implicit" and not implicit:
        wear_mode = "explicit"          # no wear coefficient: every rate is zero
    proposal, cap, wear_cycles, wear_residual, fallback = None, math.inf, 0, 0.0, 0.0
    previous = None
    while left > 0:
        step = None if on_progress is None else (
            lambda j, d=n_done, s=subs + 1: on_progress(d, total, s, j, cycle.steps))
        surfaces, pits = contact_surfaces(state, cycle.grid, life.pit_contact)
        result = cycle.evaluate(surfaces, pits, warm, step)
        n = sub_block_cycles(state, result, left, life, slab)
        depths = None
        if implicit:
            worn = implicit_sub_block(cycle, state, result, surfaces, pits, warm, n,
                                      proposal, life, cap, previous)
            cap, previous = worn.cap, worn.previous
            n, depths, proposal = worn.cycles, worn.depth, worn.proposal
            wear_cycles += worn.contact_cycles
            wear_residual = max(wear_residual, worn.residual)
            fallback += worn.fallback
        for i, bc in enumerate(result.bodies):
            intact = ~state.bodies[i].pitted[slab.rows]
            deep[i] = max(deep[i], slab.max(deep_damage_ratio(
                bc.damage_rate, DEEP_SIGNIFICANT / life.block, intact)))
        with event("apply_cycles"):
            steps = apply_cycles(state, result, n, cycle.z, slab, wear_mode, depths)
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
        pit_load_acc += n * result.pit_load
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
        slope=tuple(rms_slope(_around_pits(bs), cycle.grid.dx) for bs in b),
        wear_cycles=wear_cycles, wear_residual=wear_residual, wear_fallback=fallback / n_done,
        pit_depth_max=tuple(float(bs.pit_depth.max()) for bs in b),
        pit_load=pit_load_acc / n_done)
    return rec
