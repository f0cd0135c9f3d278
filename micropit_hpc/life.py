"""The life simulation at one contact point: blocks of ΔN load cycles (MODEL.md §5).

Per block: one load-cycle evaluation (MODEL.md §4) on the current surfaces of both bodies →
damage per cycle d(z, x, y) (Dang Van, S–N line, cycle counting) and wear per cycle Δh(x, y)
(Archard) of each body → Miner's rule D += ΔN d, wear removed and the damage columns moved up,
micropits where D ≥ 1 → surfaces updated for the next block.

**Adaptive blocks [choice]** (MODEL.md §5): a block is split into sub-blocks, each evaluated on
the surfaces the previous one left, when in one go it would change the shape of a body's surface
by more than ``max_wear_fraction`` of its initial R_q anywhere, or raise the largest damage of
the intact material by more than ``max_damage_step``, or newly pit more than ``max_pit_step``
of the window's columns. The sub-block is then cut to the wear limit, and
halved while the damage rise or the new pits are too many, but never below ΔN/``max_splits``.
ΔN stays the checkpoint and report interval.

The pit limit resolves the cascade: a pit unloads its columns onto its neighbours, whose
damage rate then jumps, so the pits grow one generation per sub-block. The damage limit leaves
out the points that fail within the sub-block, so without the pit limit a block without wear
took 1–2 sub-blocks and A_p depended on their length (64², Table 9 β_x = 30 µm, Λ = 0.176,
k_lub = 0: 5.6 % after 1 M with the default split then, 19.8 % in 100 k-cycle steps;
docs/life.md).

The shape change of a sub-block is its wear depth less the mean depth, over the intact columns
(:func:`shape_change`). A uniform removal moves the surface and its damage columns down
together and changes neither the contact nor the stresses, so it needs no split; the part of
the wear that differs from place to place is what runs the surface in, and its rate changes as
it does. Measured on the Table 9 scene (β_x = 30 µm, Λ = 0.176, k_lub = 1e-11 s, 64²): with the
split stopped at 4 sub-blocks per block the roller's A_p after 1 M cycles is 5.4 %, with 16 it
is 3.8 %, with the limit honoured (25 sub-blocks) 2.9 %, and with half the limit 3.0 %; the
coarse steps also leave a texture that shortens λ_c and runs A_p away after a few M cycles
(docs/life.md, "Resolving the running-in").

**Time integration [decision]** (``integration``): ``"adaptive"`` (default) is the split
above; ``"paper"`` is the paper's own scheme (Morales-Espejel, Rycerz & Kadiric 2018 §2.1):
fixed blocks of ΔN, one load-cycle evaluation per block on the block's starting surfaces,
damage and wear both applied over the whole block, the damage columns moved up by the worn
depth, then the pit check. In that scheme the wear–fatigue competition depends on ΔN: a point
whose life is shorter than the time wear needs to reach it still escapes if the block's wear
removes it before the check (docs/life.md, "Two time integrations").

**Wear integration [choice]** (``wear_integration``, :mod:`micropit_hpc.wear`): the wear of a
sub-block is ``relaxed`` (default: the stiff solid-contact part integrated as the linearised
pressure relief it causes) or ``explicit`` (n Δh_i, MODEL.md §4.6 as written). The split's
wear limit applies to the integrated depth.

Units: SI (metres, pascals, cycles). Physics only: no I/O, no MPI.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter

from micropit_hpc.conditions import ContactConditions
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.fatigue.dangvan import ALPHA_DV, dang_van
from micropit_hpc.fatigue.rainflow import rainflow_damage
from micropit_hpc.fatigue.sn import WoehlerLine
from micropit_hpc.parallel.petsc import event
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.pits import detach, shift_columns
from micropit_hpc.scene import INTEGRATIONS
from micropit_hpc.state import BlockRecord, BodyState, LifeState
from micropit_hpc.surfaces import Topography
from micropit_hpc.wear import WearRate, archard_wear

__all__ = ["INTEGRATIONS", "BlockRecord", "BodyCycle", "BodyState", "BodyStep", "CycleResult",
           "LifeParams", "LifeState", "apply_cycles", "deep_damage_ratio", "evaluate_cycle",
           "initial_state", "micro_cycles", "rainflow_steps", "rms_slope", "run_block",
           "shape_change", "sub_block_cycles"]


@dataclass(frozen=True)
class LifeParams:
    """Fatigue, wear and block settings of one work item (SI)."""

    k_lub: float = 0.0
    f_w: float = 10.0
    woehler: WoehlerLine = field(default_factory=WoehlerLine)
    alpha: float = ALPHA_DV
    counting: str = "sliding"
    macro_samples: int = 241
    block: float = 1e6
    max_wear_fraction: float = 0.1
    max_damage_step: float = 0.25
    max_pit_step: float = 0.01
    max_splits: int = 64
    pit_contact: str = "unloaded"
    wear_integration: str = "relaxed"
    peak_spacing_min_cells: float = 4.0
    integration: str = "adaptive"

    @classmethod
    def from_scene(cls, scene, k_lub: float) -> LifeParams:
        f, life = scene.fatigue, scene.life
        return cls(k_lub=k_lub, f_w=scene.wear.f_w,
                   woehler=WoehlerLine(f.A, f.B, f.n_min, f.low_cycle),
                   alpha=ALPHA_DV if f.alpha is None else f.alpha, counting=f.counting,
                   macro_samples=f.macro_samples, block=life.block,
                   max_wear_fraction=life.max_wear_fraction,
                   max_damage_step=life.max_damage_step, max_pit_step=life.max_pit_step,
                   max_splits=life.max_splits,
                   pit_contact=life.pit_contact, wear_integration=life.wear_integration,
                   peak_spacing_min_cells=f.peak_spacing_min_cells,
                   integration=life.integration)


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
    together) where the pressure is at the cap p_lim, i.e. where the material yields."""

    bodies: tuple[BodyCycle, BodyCycle]
    phi: float
    solid_fraction: float
    steps: int
    wall_s: float
    plastic_share: float = 0.0


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
    """Fresh bodies on the cycle's surfaces: no damage, no wear, no pits. The damage holds
    this rank's slab rows (:attr:`PositionCycle.slab`), the 2-D fields the whole window."""
    g = cycle.grid
    bodies = tuple(BodyState(heights=s.heights.copy(), damage=np.zeros(cycle.slab.local_shape),
                             pitted=np.zeros(g.shape, bool), wear=np.zeros(g.shape),
                             pit_depth=np.zeros(g.shape), rq0=s.rq)
                   for s in cycle.surfaces)
    return LifeState(bodies=bodies)


def micro_cycles(cycle: PositionCycle, body: int, lam_c: float) -> float:
    """n_μ,i = 2b |u1 − u2| / (u_i λ_c,j) micro-cycles per load cycle (MODEL.md §4.4): the
    counterface j slides 2b|u1 − u2|/u_i past a point of body i while it crosses the contact."""
    c = cycle.cond
    u_i = c.u1 if body == 1 else c.u2
    if not math.isfinite(lam_c) or c.u1 == c.u2:
        return 0.0
    return 2.0 * c.b * abs(c.u1 - c.u2) / (u_i * lam_c)


def rainflow_steps(c: ContactConditions, steps: int, lam_c: float) -> int:
    """Time steps for rainflow counting at contact ``c`` (MODEL.md §4.4): the relative slip per
    step 2b|S|/m must not exceed λ_c/4, so m ≥ 8 b |S| / λ_c; never fewer than ``steps``."""
    if not math.isfinite(lam_c) or lam_c <= 0:
        return steps
    return max(steps, math.ceil(8.0 * c.b * abs(c.S) / lam_c - 1e-9))


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
    the surface around it its load path (MODEL.md §4.5, docs/life.md)."""
    h = bs.heights + bs.pit_depth
    if not bs.pitted.any() or bs.pitted.all() or not bs.wear.any():
        return h
    intact = (~bs.pitted).astype(float)
    weight = gaussian_filter(intact, PIT_FILL_CELLS, mode="wrap")
    local = gaussian_filter(bs.wear * intact, PIT_FILL_CELLS, mode="wrap")
    around = np.where(weight > 1e-3, local / np.maximum(weight, 1e-300),
                      bs.wear[~bs.pitted].mean())
    return np.where(bs.pitted, h - np.maximum(around - bs.wear, 0.0), h)


def evaluate_cycle(cycle: PositionCycle, state: LifeState, params: LifeParams,
                   warm: dict | None = None,
                   on_step: Callable[[int], None] | None = None) -> CycleResult:
    """One load cycle on the current surfaces (MODEL.md §4): contact at every step, stresses
    and Dang Van per body, damage and wear per cycle.

    ``warm``: the contact solver's warm starts by time step, kept by the caller from one
    evaluation to the next (:meth:`PositionCycle.solve_step`); :func:`run_block` keeps them
    within a block and starts each block without, so that a run restarted from a block's
    checkpoint repeats the straight run's numbers exactly. ``on_step(j)``: called after time
    step j (1-based) of the contact, for progress reports."""
    t0 = time.perf_counter()
    g = cycle.grid
    if params.pit_contact == "unloaded":   # the surface around the pits; pits carry nothing
        tops = tuple(Topography(_around_pits(b), g.dx, g.dy, "evolved") for b in state.bodies)
        cycle.set_surfaces(tops, pits=tuple(b.pitted for b in state.bodies))
    else:
        tops = tuple(Topography(b.heights, g.dx, g.dy, "evolved") for b in state.bodies)
        cycle.set_surfaces(tops)
    lam = tuple(t.peak_spacing_x(params.peak_spacing_min_cells * g.dx) if t.rq > 0
                else math.inf for t in tops)
    fields, p_prev = [], None
    for j in range(cycle.steps):
        with event("contact"):
            f = cycle.solve_step(j, p_prev, None if warm is None else warm.setdefault(j, {}))
        fields.append(f)
        p_prev = f.pressure
        if on_step is not None:
            on_step(j + 1)
    p_sum = sum(float(f.pressure.sum()) for f in fields)
    weights = np.array([f.p_mean for f in fields])
    phi = float((weights * [f.phi for f in fields]).sum() / weights.sum()) if weights.any() else 0.0
    solid = float(np.mean([f.solid.mean() for f in fields]))
    at_lim = (1.0 - 1e-9) * cycle.p_lim
    in_contact = sum(int(np.count_nonzero(f.pressure > 0.0)) for f in fields)
    plastic = (sum(int(np.count_nonzero(f.pressure >= at_lim)) for f in fields) / in_contact
               if in_contact else 0.0)
    c = cycle.cond
    out = []
    rainflow = params.counting == "rainflow"
    for body in (1, 2):
        with event("stresses"):
            hist = np.stack([cycle.stresses(f, body) for f in fields])  # (m, 6, Nz, nx, ny)
        with event("dang_van"):
            dv = dang_van(hist, alpha=params.alpha, keep_series=rainflow)
        del hist
        q = sum(float((f.traction1 if body == 1 else f.traction2).sum()) for f in fields)
        mu_signed = q / p_sum if p_sum > 0 else 0.0
        with event("dang_van_macro"):
            macro = dang_van(cycle.macro_history(body, mu_signed, params.macro_samples),
                             alpha=params.alpha)
        tau_smooth = macro.tau_dv                                        # (Nz, 1, ny')
        lam_c = lam[2 - body]                                            # the counterface's
        n_mu = micro_cycles(cycle, body, lam_c)
        sn = params.woehler
        with event("damage_rate"):
            if rainflow:
                m = dv.series.shape[0]
                series = dv.series.reshape(m, -1)
                rate = rainflow_damage(series, sn.damage).reshape(dv.tau_dv.shape)
                low = rainflow_damage(series, sn.low_damage).reshape(dv.tau_dv.shape)
            else:
                rate = sn.damage(tau_smooth) + n_mu * sn.damage(dv.tau_dv)
                low = sn.low_damage(tau_smooth) + n_mu * sn.low_damage(dv.tau_dv)
        own, other = ((cycle.scene.body1, cycle.scene.body2) if body == 1
                      else (cycle.scene.body2, cycle.scene.body1))
        with event("wear_rate"):
            wear = archard_wear([f.pressure for f in fields], [f.solid for f in fields],
                                [cycle.slip(body, f.t) for f in fields], g.dx, c.u_s,
                                own.hardness, other.hardness, params.k_lub, params.f_w,
                                cycle.half_spaces.self_compliance)
        out.append(BodyCycle(damage_rate=rate, wear=wear, tau_rough=dv.tau_dv,
                             tau_smooth=tau_smooth, n_micro=n_mu, lam_c=lam_c,
                             damage_low=np.broadcast_to(low, rate.shape)))
    return CycleResult(bodies=tuple(out), phi=phi, solid_fraction=solid, steps=cycle.steps,
                       wall_s=time.perf_counter() - t0, plastic_share=plastic)


def apply_cycles(state: LifeState, result: CycleResult, n: float, z: np.ndarray,
                 slab: Slab | None = None, wear_integration: str = "relaxed") -> list[BodyStep]:
    """Advance both bodies by ``n`` load cycles at the rates of ``result`` (in place):
    Miner's rule, wear (heights down, damage columns up), then micropits (MODEL.md §4.4–§4.6).
    ``slab``: the rows of the damage this rank holds (default: the whole window); the pits
    found on each slab are shared so that every rank keeps the whole surface. Collective.
    Returns what it did to each body (:class:`BodyStep`)."""
    done = []
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        rows = slice(None) if slab is None else slab.rows
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
        if slab is not None:
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


def _damage_rise(state: LifeState, result: CycleResult, n: float,
                 slab: Slab | None = None) -> float:
    """Rise of the largest damage of the intact material over ``n`` cycles (points that reach
    1 pit and leave the intact material); over the whole group when ``slab`` is given."""
    group_max = (lambda v: v) if slab is None else slab.max
    rise = -math.inf
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        after = bs.damage + n * bc.damage_rate
        intact = after < 1.0
        top = group_max(float(after[intact].max()) if intact.any() else 0.0)
        rise = max(rise, top - group_max(float(bs.damage.max())))
    return rise


def _new_pits(state: LifeState, result: CycleResult, n: float,
              slab: Slab | None = None) -> float:
    """The largest share of a body's window columns that ``n`` cycles would newly pit (an
    intact column some layer of which reaches D = 1); over the whole window when ``slab`` is
    given (collective)."""
    share = 0.0
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        failing = ((bs.damage + n * bc.damage_rate) >= 1.0).any(axis=0)
        if slab is not None:
            failing = slab.allgather_rows(failing)
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


def sub_block_cycles(state: LifeState, result: CycleResult, left: float,
                     params: LifeParams, slab: Slab | None = None) -> float:
    """Cycles of the next sub-block: the adaptive split (module docstring); the whole of
    ``left`` in the paper's scheme (``integration = "paper"``)."""
    if params.integration == "paper":
        return left
    floor = params.block / params.max_splits
    n = left
    for bs, bc in zip(state.bodies, result.bodies, strict=True):
        if bs.rq0 > 0:
            n = min(n, _wear_limited(bc.wear, params.max_wear_fraction * bs.rq0, n,
                                     params.wear_integration, ~bs.pitted))
    n = max(n, min(floor, left))
    while n > floor and (_damage_rise(state, result, n, slab) > params.max_damage_step
                         or _new_pits(state, result, n, slab) > params.max_pit_step):
        n = max(0.5 * n, floor)
    if left - n <= 1e-9 * params.block:
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


def run_block(cycle: PositionCycle, state: LifeState, params: LifeParams,
              cycles: float | None = None,
              on_progress: Callable[..., None] | None = None) -> BlockRecord:
    """One block of ΔN load cycles (or ``cycles``): split adaptively
    (``integration = "adaptive"``) or in one step on the block's starting surfaces (the
    paper's scheme, ``"paper"``); returns its record. Collective over the cycle's group
    (every rank returns the same record).
    ``on_progress(cycles_done, block_cycles, sub_block, step, steps)``: called after every
    time step of every sub-block's load cycle (progress reports; changes nothing)."""
    t0 = time.perf_counter()
    slab = cycle.slab
    left = params.block if cycles is None else cycles
    subs, phi_acc, plastic_acc, n_done, wear_step, pit_step = 0, 0.0, 0.0, 0.0, 0.0, 0.0
    new_pits, low_pits = [0, 0], [0, 0]
    added, low_added, deep = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]
    result, warm = None, {}
    total = left
    while left > 0:
        step = None if on_progress is None else (
            lambda j, d=n_done, s=subs + 1: on_progress(d, total, s, j, cycle.steps))
        result = evaluate_cycle(cycle, state, params, warm, step)
        n = sub_block_cycles(state, result, left, params, slab)
        for i, bc in enumerate(result.bodies):
            intact = ~state.bodies[i].pitted[slab.rows]
            deep[i] = max(deep[i], slab.max(deep_damage_ratio(
                bc.damage_rate, DEEP_SIGNIFICANT / params.block, intact)))
        with event("apply_cycles"):
            steps = apply_cycles(state, result, n, cycle.z, slab, params.wear_integration)
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
