"""The dynamic balance's queue order, replayed on a finished study's item times: how long each
block would take on G groups if its items were handed out, as groups free up, in

* ``item``: item order (block 1's order before :meth:`Plan.queue_order`);
* ``prior``: :meth:`Plan.queue_order` (every block's order now: k_lub, then the transit's
  slip 2b|S|; no times needed);
* ``last``: longest first by the block before's times (the later blocks' order before);
* ``oracle``: longest first by the block's own times (not knowable before the block runs);

each against the bound max(Σt/G, max t) that no order beats. A replay: every item takes the
time it took in the measured run (``history/item_*/wall_s`` of its results.h5) whatever group
runs it, with no time to hand an item out or to share the states. So it isolates the order;
it is not a wall time.

    python benchmarks/bench_queue_order.py runs/s50/study33_dyn2/np2-rpi1 [more runs] \
        --groups 2 3 4 6 8 16

Prints one line per block and G: the bound [s] and each order's time over the bound,
averaged over the runs given (the same scene and items in each; their times differ by the
machine's noise).
"""

from __future__ import annotations

import argparse
import heapq
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from micropit_hpc.io.results import load_results  # noqa: E402
from micropit_hpc.plan import make_plan  # noqa: E402
from micropit_hpc.scene import scene_from_dict  # noqa: E402


def makespan(times: np.ndarray, order, groups: int) -> float:
    """The time until the last group is done when the items go out in ``order`` to
    whichever of ``groups`` groups is free first (list scheduling)."""
    free = [0.0] * groups
    for i in order:
        heapq.heappush(free, heapq.heappop(free) + float(times[i]))
    return max(free)


def item_times(run: Path) -> tuple[np.ndarray, list[int], dict]:
    """(times [item, block] in s, the item ids, the scene document) of a finished run."""
    res = load_results(run)
    ids = res.ids
    times = np.array([res.history[i]["wall_s"] for i in ids], dtype=float)
    return times, ids, res.scene


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="run folders (or results.h5) of one scene")
    ap.add_argument("--groups", type=int, nargs="+", default=[2, 3, 4, 6, 8, 16])
    a = ap.parse_args(argv)
    runs = [item_times(Path(r)) for r in a.runs]
    times0, ids, doc = runs[0]
    plan = make_plan(scene_from_dict(doc, a.runs[0]))
    if [it.id for it in plan.items] != ids or any(r[1] != ids for r in runs):
        print("bench_queue_order: the runs' items are not the scene's whole study (run with "
              "--position?): give runs of one whole study", file=sys.stderr)
        return 2
    prior = plan.queue_order()
    blocks = min(r[0].shape[1] for r in runs)
    print(f"# {len(ids)} items, {blocks} blocks, {len(runs)} run(s); time over the bound, "
          "mean over the runs")
    print(f"{'block':>5} {'G':>3} {'bound [s]':>10} {'item':>7} {'prior':>7} {'last':>7} "
          f"{'oracle':>7}")
    for b in range(blocks):
        for g in a.groups:
            ratios, bounds = {k: [] for k in ("item", "prior", "last", "oracle")}, []
            for times, _, _ in runs:
                t = times[:, b]
                bound = max(t.sum() / g, t.max())
                orders = {"item": range(len(t)), "prior": prior,
                          "last": np.lexsort((np.arange(len(t)), -times[:, b - 1])) if b
                          else None,
                          "oracle": np.lexsort((np.arange(len(t)), -t))}
                bounds.append(bound)
                for k, o in orders.items():
                    ratios[k].append(np.nan if o is None else makespan(t, o, g) / bound)
            cells = " ".join(f"{np.mean(v):7.3f}" if not np.isnan(v).any() else f"{'—':>7}"
                             for v in ratios.values())
            print(f"{b + 1:>5} {g:>3} {np.mean(bounds):>10.1f} {cells}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
