"""The evolving state of a work item and the record of each block, each field declared once.

:class:`BodyState` holds what a body carries from block to block (docs/model.md §5): its
surface, its Miner damage on the layers below it, its pits and its wear. Each of its array
fields declares, in its metadata (:func:`state_field`), its unit, its dtype on disk, whether it
is layered (N_z, n_x, n_y: split over the ranks of a group by x rows) and what it means.
Checkpoints (:mod:`micropit_hpc.runner`), the final maps of results.h5
(:mod:`micropit_hpc.io.results`) and the gathering of the maps (:mod:`micropit_hpc.study`)
iterate :data:`BODY_FIELDS`, so adding a field to the state is one change here
(docs/architecture.md).

:class:`BlockRecord` is what a block reports; its fields declare their unit the same way, and
its flat float row (the checkpoint's ``records``, :data:`RECORD_FIELDS`) is derived from them.
"""

from __future__ import annotations

from dataclasses import MISSING, astuple, dataclass, field, fields

import numpy as np

__all__ = ["BODY_FIELDS", "ITEM_STATE", "RECORD_FIELDS", "RECORD_UNITS", "BlockRecord",
           "BodyState", "LifeState", "StateField", "carried", "item_state_row",
           "record_from_row", "record_row", "restore_carried", "restore_item_state"]

_STATE = "micropit_state"
_UNIT = "micropit_unit"


@dataclass(frozen=True)
class StateField:
    """How one array of :class:`BodyState` is stored: ``name`` (the attribute and the dataset
    name under ``bodyB/``), ``unit`` ("1" for a pure number), ``dtype`` on disk, ``layered``
    (an (N_z, n_x, n_y) field whose x rows are split over the ranks of a group; otherwise the
    whole (n_x, n_y) window on every rank) and ``meaning``."""

    name: str
    unit: str
    dtype: str
    layered: bool
    meaning: str


def state_field(unit: str, meaning: str, dtype: str = "f8", layered: bool = False):
    """A :class:`BodyState` array field with its storage declared (see :class:`StateField`)."""
    return field(metadata={_STATE: (unit, dtype, layered, meaning)})


def unit(u: str, default=MISSING):
    """A record field with its unit (``"1"`` for a pure number); required without
    ``default``."""
    return field(default=default, metadata={_UNIT: u})


@dataclass
class BodyState:
    """The evolving state of one body of a work item (material frame, SI). ``rq0``: the
    initial R_q, the adaptive split's yardstick (docs/model.md §5)."""

    heights: np.ndarray = state_field("m", "surface heights (material frame)")
    damage: np.ndarray = state_field("1", "Miner damage on the layers below the local "
                                          "surface", layered=True)
    pitted: np.ndarray = state_field("1", "columns that have lost material to a micropit",
                                     dtype="u1")
    wear: np.ndarray = state_field("m", "cumulative wear depth")
    pit_depth: np.ndarray = state_field("m", "cumulative depth lost to micropits")
    rq0: float = field(default=MISSING)

    @classmethod
    def fresh(cls, heights: np.ndarray, layered_shape: tuple[int, ...],
              rq0: float) -> BodyState:
        """A body before its first cycle: the surface ``heights`` (copied) of R_q ``rq0``,
        every other declared array zero (``layered_shape``: this rank's part of a layered
        field)."""
        arrays = {f.name: np.zeros(layered_shape if f.layered else heights.shape,
                                   dtype=bool if f.dtype == "u1" else float)
                  for f in BODY_FIELDS if f.name != "heights"}
        return cls(heights=heights.copy(), **arrays, rq0=rq0)

    @property
    def Ap(self) -> float:
        """Micropitted area fraction A_p [%] (docs/model.md §4.5)."""
        return 100.0 * float(self.pitted.mean())

    @property
    def rq(self) -> float:
        return float(self.heights.std())


#: The stored arrays of a body, in declaration order.
BODY_FIELDS: tuple[StateField, ...] = tuple(
    StateField(f.name, *f.metadata[_STATE]) for f in fields(BodyState) if _STATE in f.metadata)


@dataclass
class LifeState:
    """Both bodies of a work item, the cycles and blocks done."""

    bodies: tuple[BodyState, BodyState]
    cycles: float = 0.0
    block: int = 0


#: The scalars of an item's state as stored (the checkpoint's ``state`` row), in order.
ITEM_STATE = ("cycles", "block", "rq0 of body 1", "rq0 of body 2")


def item_state_row(state: LifeState) -> np.ndarray:
    """The :data:`ITEM_STATE` row of ``state``."""
    return np.array([state.cycles, state.block, state.bodies[0].rq0, state.bodies[1].rq0])


def restore_item_state(state: LifeState, row: np.ndarray) -> None:
    """Set the scalars of ``state`` from an :data:`ITEM_STATE` row (in place)."""
    state.cycles, state.block = float(row[0]), int(row[1])
    for b, bs in enumerate(state.bodies):
        bs.rq0 = float(row[2 + b])


def carried(state: LifeState) -> list[np.ndarray]:
    """What a work item carries from block to block on this rank, the checkpoint's content as
    contiguous arrays in a fixed order: the :data:`ITEM_STATE` row, then each body's
    :data:`BODY_FIELDS` (a layered field: this rank's rows). An item moved to another group
    (:meth:`micropit_hpc.study.Study.reassign`) is sent as these and rebuilt by
    :func:`restore_carried`."""
    return [item_state_row(state)] + [np.ascontiguousarray(getattr(bs, f.name))
                                      for bs in state.bodies for f in BODY_FIELDS]


def restore_carried(state: LifeState, parts: list[np.ndarray]) -> None:
    """Set ``state`` (in place) from the arrays of :func:`carried`."""
    restore_item_state(state, parts[0])
    fields = iter(parts[1:])
    for bs in state.bodies:
        for f in BODY_FIELDS:
            setattr(bs, f.name, next(fields))


@dataclass(frozen=True)
class BlockRecord:
    """The state at the end of a block (one value per body where a pair). ``wear_step``: the
    largest shape change one sub-block's wear made (:func:`micropit_hpc.life.shape_change`),
    over the body's initial R_q (the split aims at ≤ ``max_wear_fraction``; above it the split
    stopped at ``max_splits``). ``pit_step``: the largest share of the window's columns one
    sub-block newly pitted on either body (the split aims at ≤ ``max_pit_step``).

    The model's range (:mod:`micropit_hpc.regime` turns these into flags and warnings):
    ``low_cycle_damage``: the share of the block's damage (summed over the material points)
    that came from N < n_min; ``low_cycle_pits``: the share of the block's newly pitted
    columns whose failing point took most of its damage from N < n_min (0 without new pits);
    ``plastic_share``: the share of the contact area at p_lim (the block's evaluations,
    weighted by their cycles); ``deep_damage``: :func:`micropit_hpc.life.deep_damage_ratio`,
    the largest over the block's evaluations; ``slope``: each surface's RMS slope Δq along x
    at the end of the block, of the surface the contact sees (the pits filled: their walls
    carry no load) [rad]; ``pit_depth_max``: the deepest cumulative pit of each body [m].

    The implicit wear (``life.wear_integration = "implicit"``): ``wear_cycles``, the
    contact-only load cycles its solves took in the block; ``wear_residual``, the largest
    residual max |r − ⟨r⟩|, r = n Δh(w) − w, of an accepted step over R_q (its mean is solved
    exactly, :func:`~micropit_hpc.implicit_wear.backward_euler`; above ``life.wear_tol`` where a
    step of the smallest length did not converge); ``wear_fallback``, the share of the block's
    cycles whose wear the relaxed update integrated because a sub-block spent its budget of
    contact-only cycles (:data:`micropit_hpc.life.WEAR_BUDGET`).

    ``pit_load``: the share of the contact load that the solves put on pitted columns and that
    the unloading (``life.pit_contact = "unloaded"``) moved to the other columns as a film's
    pressure (:attr:`micropit_hpc.cycle.CycleResult.pit_load`; the block's evaluations,
    weighted by their cycles)."""

    block: int = unit("1")
    cycles: float = unit("1")
    sub_blocks: int = unit("1")
    phi: float = unit("1")
    wall_s: float = unit("s")
    Ap: tuple[float, float] = unit("%")
    max_damage: tuple[float, float] = unit("1")
    wear_mean: tuple[float, float] = unit("m")
    wear_max: tuple[float, float] = unit("m")
    Rq: tuple[float, float] = unit("m")
    n_micro: tuple[float, float] = unit("1")
    wear_step: float = unit("1", 0.0)
    pit_step: float = unit("1", 0.0)
    low_cycle_damage: tuple[float, float] = unit("1", (0.0, 0.0))
    low_cycle_pits: tuple[float, float] = unit("1", (0.0, 0.0))
    plastic_share: float = unit("1", 0.0)
    deep_damage: tuple[float, float] = unit("1", (0.0, 0.0))
    slope: tuple[float, float] = unit("rad", (0.0, 0.0))
    pit_depth_max: tuple[float, float] = unit("m", (0.0, 0.0))
    wear_cycles: int = unit("1", 0)
    wear_residual: float = unit("1", 0.0)
    wear_fallback: float = unit("1", 0.0)
    pit_load: float = unit("1", 0.0)


def _kind(f) -> str:
    """``int``, ``float`` or ``pair`` from a record field's annotation."""
    t = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
    return "pair" if t.startswith("tuple") else t


#: Unit of each :class:`BlockRecord` field (results.h5 ``history/``).
RECORD_UNITS: dict[str, str] = {f.name: f.metadata[_UNIT] for f in fields(BlockRecord)}

#: Columns of the ``records`` checkpoint field: BlockRecord's fields, pairs flattened.
RECORD_FIELDS: tuple[str, ...] = tuple(
    name for f in fields(BlockRecord)
    for name in ((f.name + "1", f.name + "2") if _kind(f) == "pair" else (f.name,)))


def record_row(rec: BlockRecord) -> np.ndarray:
    """A BlockRecord as one float64 row of :data:`RECORD_FIELDS`."""
    out = []
    for v in astuple(rec):
        out.extend(v if isinstance(v, tuple) else (v,))
    return np.array(out, dtype=float)


def record_from_row(row: np.ndarray) -> BlockRecord:
    """The BlockRecord of a :func:`record_row` row (exact round trip)."""
    vals, i = {}, 0
    for f in fields(BlockRecord):
        kind = _kind(f)
        if kind == "pair":
            vals[f.name], i = (float(row[i]), float(row[i + 1])), i + 2
        else:
            vals[f.name], i = (int(row[i]) if kind == "int" else float(row[i])), i + 1
    return BlockRecord(**vals)
