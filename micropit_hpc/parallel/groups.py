"""Level-1 parallelism: independent work items spread over groups of ranks (docs/hpc.md §2).

``COMM_WORLD`` is split into groups of ``ranks_per_item`` contiguous ranks; each group works
through its share of the work items (mesh positions × wear coefficients × roughness patches)
with its own communicator. The share is a pure function of the item count, the group count
and the optional item costs, so every rank computes the same assignment without talking.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence
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


def assign_items(n_items: int, n_groups: int,
                 costs: Sequence[float] | None = None) -> list[list[int]]:
    """Work items ``0 … n_items-1`` for each of ``n_groups`` groups, each list ascending.

    Without costs: round robin (item ``i`` goes to group ``i % n_groups``). With costs:
    longest-first greedy; items in order of decreasing cost (ties: lower item id first) each go
    to the group with the least load so far (ties: fewer items, then lower group index). A pure
    function, so every rank computes the same assignment.
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
    order = np.lexsort((np.arange(n_items), -c))  # decreasing cost, then increasing id
    # (load, items, group): least load; on equal loads fewer items (so zero-cost items still
    # spread out), then the lowest group index.
    heap = [(0.0, 0, g) for g in range(n_groups)]
    out: list[list[int]] = [[] for _ in range(n_groups)]
    for item in order.tolist():  # a loop over work items, not grid points
        load, n, g = heapq.heappop(heap)
        out[g].append(item)
        heapq.heappush(heap, (load + float(c[item]), n + 1, g))
    return [sorted(items) for items in out]
