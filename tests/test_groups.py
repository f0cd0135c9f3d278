"""Work-item groups and the item assignment every rank computes alike (docs/hpc.md §2, level 1)."""

from __future__ import annotations

import numpy as np
import pytest

from micropit_hpc.errors import MicropitError
from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.groups import (
    ItemQueue,
    assign_items,
    fair_share,
    move_items,
    share_items,
    split_groups,
)


class RecordingComm:
    """A stand-in for one rank of a larger communicator that records its Split call."""

    def __init__(self, rank, size):
        self.rank, self.size, self.calls = rank, size, []

    def Split(self, color=0, key=0):
        self.calls.append((color, key))
        return SerialComm()


def test_serial_comm_is_one_group_of_one_rank():
    world = SerialComm()
    g = split_groups(world, 1)
    assert (g.index, g.count, g.size, g.is_root) == (0, 1, 1, True)
    assert g.world is world
    assert g.comm.allreduce(7) == 7
    assert (g.comm.Get_rank(), g.comm.Get_size()) == (0, 1)
    assert g.items(assign_items(3, g.count)) == [0, 1, 2]


@pytest.mark.parametrize("rank,per_item,color,count", [(0, 2, 0, 3), (3, 2, 1, 3), (5, 2, 2, 3),
                                                       (5, 3, 1, 2), (5, 6, 0, 1)])
def test_contiguous_ranks_form_a_group(rank, per_item, color, count):
    comm = RecordingComm(rank, 6)
    g = split_groups(comm, per_item)
    assert comm.calls == [(color, rank)]  # color = rank // per_item, order kept by key
    assert (g.index, g.count) == (color, count)


@pytest.mark.parametrize("size,per_item,text", [(5, 2, "multiple of ranks_per_item"),
                                                (4, 0, "at least 1"), (4, -1, "at least 1"),
                                                (4, 1.5, "integer")])
def test_impossible_splits_are_refused(size, per_item, text):
    comm = RecordingComm(0, size)
    with pytest.raises(MicropitError, match=text):
        split_groups(comm, per_item)
    assert comm.calls == []  # refused before any collective call


def test_round_robin_without_costs():
    assert assign_items(7, 3) == [[0, 3, 6], [1, 4], [2, 5]]
    assert assign_items(2, 4) == [[0], [1], [], []]
    assert assign_items(0, 2) == [[], []]


def test_longest_first_greedy_by_cost():
    # 5 -> g0; 3 -> g1; 3 -> g1 (3 < 5); 2 -> g0 (5 < 6); 2 -> g1 (6 < 7); 1 -> g0 (7 < 8)
    assert assign_items(6, 2, [5, 3, 3, 2, 2, 1]) == [[0, 3, 5], [1, 2, 4]]
    # The input order does not matter, only the costs (and item ids for ties).
    assert assign_items(6, 2, [1, 2, 2, 3, 3, 5]) == [[0, 1, 5], [2, 3, 4]]


def test_ties_go_to_the_lower_item_id_and_lower_group_index():
    assert assign_items(4, 3, [1.0, 1.0, 1.0, 1.0]) == [[0, 3], [1], [2]]
    assert assign_items(3, 3, [0.0, 0.0, 0.0]) == [[0], [1], [2]]


def test_greedy_assignment_covers_every_item_once_and_balances():
    rng = np.random.default_rng(3)
    costs = rng.lognormal(0.0, 1.0, 200)
    groups = assign_items(200, 7, costs)
    flat = sorted(i for g in groups for i in g)
    assert flat == list(range(200))
    assert all(g == sorted(g) for g in groups)
    loads = np.array([costs[g].sum() for g in groups])
    # Longest-first is within one item's cost of the mean load (greedy list scheduling).
    assert loads.max() <= costs.sum() / 7 + costs.max()
    assert loads.max() - loads.min() < 0.5 * loads.mean()
    assert groups == assign_items(200, 7, list(costs))  # pure: same input, same answer


def test_no_group_holds_more_than_its_share():
    # one heavy item and many light ones: unlimited, the light ones all go to the other group
    costs = [10.0] + [1.0] * 9
    assert assign_items(10, 2, costs) == [[0], list(range(1, 10))]
    capped = assign_items(10, 2, costs, most=fair_share(10, 2))
    assert [len(g) for g in capped] == [5, 5] and capped[0][0] == 0
    assert sorted(i for g in capped for i in g) == list(range(10))
    assert fair_share(33, 2) == 17 and fair_share(4, 2) == 2 and fair_share(1, 3) == 1
    with pytest.raises(MicropitError, match="do not fit 2 groups of at most 4"):
        assign_items(10, 2, costs, most=4)


@pytest.mark.parametrize("n,groups,costs,text", [(3, 0, None, "at least 1"),
                                                 (-1, 2, None, "negative"),
                                                 (3, 2, [1.0, 2.0], "need 3 costs"),
                                                 (2, 2, [1.0, -1.0], "non-negative"),
                                                 (2, 2, [1.0, np.nan], "finite")])
def test_bad_assignment_arguments(n, groups, costs, text):
    with pytest.raises(MicropitError, match=text):
        assign_items(n, groups, costs)


def all_ranks_agree(comm, ok: bool) -> bool:
    return all(comm.allgather(bool(ok)))


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_groups_on_mpi_ranks():
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    size = world.size
    ones = split_groups(world, 1)
    ok = (ones.index == world.rank and ones.count == size and ones.size == 1 and ones.is_root)
    whole = split_groups(world, size)
    total = whole.comm.allreduce(world.rank + 1)
    ok = ok and whole.count == 1 and whole.is_root == (world.rank == 0)
    ok = ok and total == size * (size + 1) // 2 and whole.comm.rank == world.rank
    assignment = assign_items(11, ones.count, costs=np.arange(11.0) % 4)
    ok = ok and all(a == assignment for a in world.allgather(assignment))
    mine = world.allgather(ones.items(assignment))
    ok = ok and sorted(i for m in mine for i in m) == list(range(11))
    ones.free()
    whole.free()
    assert all_ranks_agree(world, ok)
    with pytest.raises(MicropitError, match="multiple"):
        split_groups(world, size + 1)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_the_item_queue_hands_every_item_out_once():
    """Groups that take items at different speeds: every item goes out once, to whichever group
    asks, none to a group beyond its share; then None for good (docs/hpc.md §2)."""
    import time

    from mpi4py import MPI

    world = MPI.COMM_WORLD
    ok = True
    for per_item, n, order in ((1, 7, None), (1, 1, None), (world.size, 5, None),
                               (1, 6, [4, 0, 5, 2, 1, 3])):
        group = split_groups(world, per_item)
        most = fair_share(n, group.count)
        queue = ItemQueue(group, n, most, order)
        taken = []
        while (got := queue.take()) is not None:
            taken.append(got)
            time.sleep(0.01 * (1 + group.index))     # the groups free up at other times
        ok = ok and queue.take() is None and len(taken) <= most
        queue.close()
        # every rank of a group saw the same items; every item went to exactly one group,
        # each group's in the order given, with its place in that order
        ok = ok and all(t == taken for t in group.comm.allgather(taken))
        roots = world.allgather(taken if group.is_root else [])
        seq = list(range(n)) if order is None else order
        ok = ok and sorted(i for t in roots for i, _ in t) == list(range(n))
        ok = ok and all(i == seq[q] for t in roots for i, q in t)
        ok = ok and all([q for _, q in t] == sorted(q for _, q in t) for t in roots)
        group.free()
    assert all_ranks_agree(world, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_items_that_change_group_arrive_whole_and_the_rest_stay():
    """move_items: each moved item's arrays (floats, a bool mask, a row) reach rank j of its new
    group from rank j of its old one, unchanged; items that keep their group are not asked."""
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    group = split_groups(world, 1)
    n = 2 * group.count + 1
    old = assign_items(n, group.count)
    # every item one group on, but item 0, which stays
    new = [[i for i in range(n) if (0 if i == 0 else (i + 1) % group.count) == g]
           for g in range(group.count)]

    def arrays(i):
        return [np.full((3, 4), float(i)), np.arange(5) % (i + 2) == 0, np.array([i, -i])]

    given, got = [], {}

    def give(i):
        given.append(i)
        return arrays(i)

    def receive(i):
        got[i] = [np.empty_like(a) for a in arrays(i)]
        return got[i]

    move_items(group, old, new, give, receive)
    ok = sorted(given) == sorted(i for i in old[group.index] if i not in new[group.index])
    ok = ok and sorted(got) == sorted(i for i in new[group.index] if i not in old[group.index])
    ok = ok and all(a.dtype == b.dtype and np.array_equal(a, b) for i in got
                    for a, b in zip(got[i], arrays(i), strict=True))
    group.free()
    assert all_ranks_agree(world, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(60)
def test_every_group_gets_every_items_arrays_from_the_same_rank_of_its_group():
    """share_items: rank j of every group ends with each item's arrays as rank j of the group
    that holds it gave them (groups of one rank, and one group of every rank)."""
    from mpi4py import MPI

    world = MPI.COMM_WORLD
    ok = True
    for per_item in (1, world.size):
        group = split_groups(world, per_item)
        n = 2 * group.count + 1
        mine = assign_items(n, group.count)[group.index]
        held = {i: [np.full(3, 10.0 * i + group.comm.rank), np.arange(4) < i] for i in mine}
        got = share_items(group, held)
        ok = ok and sorted(got) == list(range(n))
        ok = ok and all(np.array_equal(got[i][0], np.full(3, 10.0 * i + group.comm.rank))
                        and np.array_equal(got[i][1], np.arange(4) < i) for i in got)
        group.free()
    assert all_ranks_agree(world, ok)
