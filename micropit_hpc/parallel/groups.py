"""Level-1 parallelism: independent work items spread over groups of ranks (docs/hpc.md §2).

``COMM_WORLD`` is split into groups of ``ranks_per_item`` contiguous ranks; each group works
through its share of the work items (mesh positions × wear coefficients × roughness patches)
with its own communicator. The share is a pure function of the item count, the group count
and the optional item costs, so every rank computes the same assignment without talking.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from micropit_hpc.errors import MicropitError, collective


@dataclass(frozen=True)
class Group:
    """This rank's group: its communicator, its number among ``count`` groups, the parent."""

    comm: Any
    index: int
    count: int
    world: Any

    @property
    def is_root(self) -> bool:
        """True on rank 0 of the group (the rank that reports for it)."""
        return self.comm.rank == 0

    @property
    def size(self) -> int:
        """The number of ranks in the group (``ranks_per_item``)."""
        return self.comm.size

    def items(self, assignment: Sequence[Sequence[int]]) -> list[int]:
        """This group's work items in an :func:`assign_items` result."""
        return list(assignment[self.index])

    def free(self) -> None:
        """Release the group communicator (collective over the group)."""
        if self.comm is not self.world:
            self.comm.Free()


def split_groups(comm, ranks_per_item: int) -> Group:
    """Split ``comm`` into groups of ``ranks_per_item`` contiguous ranks (collective).

    Group ``g`` holds world ranks ``g*ranks_per_item … (g+1)*ranks_per_item - 1`` in that order.
    Works with :class:`~micropit_hpc.parallel.SerialComm` (one group of one rank).
    """
    if isinstance(ranks_per_item, bool) or not isinstance(ranks_per_item, int | np.integer):
        raise MicropitError(f"ranks_per_item must be an integer, got {ranks_per_item!r}")
    if ranks_per_item < 1:
        raise MicropitError(f"ranks_per_item must be at least 1, got {ranks_per_item}")
    size, rank = comm.size, comm.rank
    if size % ranks_per_item:
        lower = size - size % ranks_per_item
        upper = size + ranks_per_item - size % ranks_per_item
        hint = f"{lower} or {upper} ranks" if lower >= ranks_per_item else f"{upper} ranks"
        raise collective(MicropitError(
            f"--ranks-per-item {ranks_per_item}: {size} MPI ranks cannot be split into groups "
            f"of {ranks_per_item} ranks per work item: the number of ranks must be a multiple of "
            f"ranks_per_item (run on {hint}, or choose a divisor of {size})"))
    index = rank // int(ranks_per_item)
    sub = comm.Split(color=index, key=rank)
    return Group(comm=sub, index=index, count=size // int(ranks_per_item), world=comm)


def assign_items(n_items: int, n_groups: int, costs: Sequence[float] | None = None,
                 most: int | None = None) -> list[list[int]]:
    """Work items ``0 … n_items-1`` for each of ``n_groups`` groups, each list ascending.

    Without costs: round robin (item ``i`` goes to group ``i % n_groups``). With costs:
    longest-first greedy; items in order of decreasing cost (ties: lower item id first) each go
    to the group with the least load so far (ties: fewer items, then lower group index) among
    those that hold fewer than ``most`` items (None: no limit; at least ⌈n_items/n_groups⌉).
    A pure function, so every rank computes the same assignment.
    """
    if n_groups < 1:
        raise MicropitError(f"the number of groups must be at least 1, got {n_groups}")
    if n_items < 0:
        raise MicropitError(f"the number of work items cannot be negative, got {n_items}")
    if costs is None:
        return [list(range(g, n_items, n_groups)) for g in range(n_groups)]
    c = np.asarray(costs, dtype=float)
    if c.shape != (n_items,):
        raise MicropitError(f"{n_items} work items need {n_items} costs, got {c.size}")
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise MicropitError("work-item costs must be finite and non-negative")
    if most is not None and most * n_groups < n_items:
        raise MicropitError(f"{n_items} work items do not fit {n_groups} groups of at most "
                            f"{most} items")
    order = np.lexsort((np.arange(n_items), -c))  # decreasing cost, then increasing id
    # (load, items, group): least load; on equal loads fewer items (so zero-cost items still
    # spread out), then the lowest group index. A full group leaves the heap.
    heap = [(0.0, 0, g) for g in range(n_groups)]
    out: list[list[int]] = [[] for _ in range(n_groups)]
    for item in order.tolist():  # a loop over work items, not grid points
        load, n, g = heapq.heappop(heap)
        out[g].append(item)
        if most is None or n + 1 < most:
            heapq.heappush(heap, (load + float(c[item]), n + 1, g))
    return [sorted(items) for items in out]


def fair_share(n_items: int, n_groups: int) -> int:
    """The most items a group holds: ⌈n_items/n_groups⌉ (what the memory estimate assumes,
    :mod:`micropit_hpc.estimate`)."""
    return -(-n_items // n_groups)


#: The MPI tag of a work item's state moving between groups (:func:`move_items`).
MOVE_TAG = 7411


def move_items(group: Group, old: Sequence[Sequence[int]], new: Sequence[Sequence[int]],
               give: Callable[[int], list[np.ndarray]],
               receive: Callable[[int], list[np.ndarray]]) -> None:
    """Move the work items whose group differs between the assignments ``old`` and ``new``
    (collective over the world): for each, in item order, ``give(item)`` on every rank j of its
    old group returns the contiguous arrays that rank sends to rank j of the new group (groups
    are of one size, so their slabs match), where ``receive(item)`` (collective over that
    group) returns the arrays of the same shapes and types to fill. Every send is posted
    before any receive, so no rank waits for another; a pair of ranks' messages keep their
    order."""
    old_of = {i: g for g, ids in enumerate(old) for i in ids}
    new_of = {i: g for g, ids in enumerate(new) for i in ids}
    moving = sorted(i for i in old_of if old_of[i] != new_of[i])
    size, me, j = group.size, group.index, group.comm.rank
    sends, kept = [], []        # the arrays sent stay alive until their sends are done
    for i in moving:
        if old_of[i] == me:
            kept.append(give(i))
            sends += [group.world.Isend(a, dest=new_of[i] * size + j, tag=MOVE_TAG)
                      for a in kept[-1]]
    for i in moving:
        if new_of[i] == me:
            for a in receive(i):
                group.world.Recv(a, source=old_of[i] * size + j, tag=MOVE_TAG)
    for r in sends:
        r.Wait()


def share_items(group: Group, held: dict[int, list[np.ndarray]]) -> dict[int, list]:
    """Every group's ``held`` {item: arrays} on rank j of every group, from rank j of the group
    that holds the item (collective over the world: an allgather over the ranks j)."""
    column = group.world.Split(color=group.comm.rank, key=group.index)
    parts = column.allgather(held)
    column.Free()
    out: dict[int, list] = {}
    for part in parts:
        out.update(part)
    return out


class ItemQueue:
    """The work items of a block handed out one at a time, in the given ``order`` (default:
    item order), to whichever group asks first, none to a group that holds ``most`` of them:
    a counter on world rank 0 that a group root advances with MPI's one-sided atomic
    fetch-and-add (passive target, so no rank waits for another to answer; across nodes an MPI
    without hardware atomics may answer only when rank 0 next enters MPI), the value
    broadcast to the rest of its group. Creating and :meth:`close` are collective over the
    world; :meth:`take` over the group. Needs mpi4py (more than one group)."""

    def __init__(self, group: Group, n_items: int, most: int,
                 order: Sequence[int] | None = None):
        from mpi4py import MPI

        self._mpi, self.group, self.n, self.most, self.taken = MPI, group, n_items, most, 0
        self.order = list(range(n_items)) if order is None else list(order)
        world = group.world
        self._win = MPI.Win.Allocate(8 if world.rank == 0 else 0, 8, comm=world)
        if world.rank == 0:
            self._win.Lock(0, MPI.LOCK_EXCLUSIVE)
            self._win.Put(np.zeros(1, np.int64), 0)
            self._win.Unlock(0)
        world.Barrier()

    def take(self) -> tuple[int, int] | None:
        """(the next item, its place in the order), or None once every item is out or this
        group holds ``most``. Collective over the group."""
        q = None
        if self.group.is_root and self.taken < self.most:
            got = np.zeros(1, np.int64)
            self._win.Lock(0, self._mpi.LOCK_SHARED)
            self._win.Fetch_and_op(np.ones(1, np.int64), got, 0, 0, self._mpi.SUM)
            self._win.Unlock(0)
            q = int(got[0]) if got[0] < self.n else None
        q = self.group.comm.bcast(q, root=0)
        if q is None:
            return None
        self.taken += 1
        return self.order[q], q

    def close(self) -> None:
        """Free the counter (collective over the world)."""
        self._win.Free()
