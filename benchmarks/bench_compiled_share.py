"""How much of one work item's block is compiled work that no Python trimming can remove: the
FFTW transforms (``pyfftw`` ``execute``) and the compiled Dang Van kernel
(``DangVanStream._feed_compiled``), timed under ``cProfile`` in a second run of the same block,
against the wall time of a first run without the profiler (docs/performance.md §3, "The
compiled floor"). The item as ``bench_item_profile.py`` makes it (the scene's converged default,
one 256² realisation resampled to ``--n``); ``--after-M`` first runs that many cycles of the
item unmeasured, to time a stretch later in its life.

    python benchmarks/bench_compiled_share.py --position 3 --k-lub 5e-11 --cycles-M 0.3
    python benchmarks/bench_compiled_share.py --position 3 --k-lub 5e-11 --after-M 0.3 \\
        --cycles-M 0.1

One core, one process; timings, not tests.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_item_profile import add_item_arguments, item_from_arguments

FFT = "<method 'execute' of 'pyfftw.pyfftw.FFTW' objects>"
DANG_VAN = "_feed_compiled"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_item_arguments(ap, position=3, cycles_M=0.3)
    ap.add_argument("--after-M", type=float, default=0.0,
                    help="cycles [M] run first, unmeasured")
    a = ap.parse_args(argv)
    measured = a.cycles_M
    a.cycles_M += a.after_M         # the item's block holds both stretches

    def item():
        run = item_from_arguments(a)
        if a.after_M > 0.0:
            run.run_block(a.after_M * 1e6)
        return run
    run = item()
    t0 = time.perf_counter()
    run.run_block(measured * 1e6)
    plain = time.perf_counter() - t0
    run = item()
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    rec = run.run_block(measured * 1e6)
    prof.disable()
    profiled = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    fft = sum(v[2] for k, v in stats.items() if k[2] == FFT)
    dv = sum(v[2] for k, v in stats.items() if k[2] == DANG_VAN)
    print(f"position {a.position}, k_lub {a.k_lub:g} s, {a.n}², {measured:g} M after "
          f"{a.after_M:g} M: "
          f"{plain:.1f} s ({profiled:.1f} s profiled); FFT {fft:.1f} s, Dang Van kernel "
          f"{dv:.1f} s: {(fft + dv) / plain:.1%} of the plain run; sub-blocks "
          f"{rec.sub_blocks}, contact-only cycles {rec.wear_cycles}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
