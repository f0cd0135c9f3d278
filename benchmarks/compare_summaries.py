"""Compare two study summaries (summary.csv) row by row: A_p in points and the combined wear
in per cent of the reference, per (position, k_lub, body, cycles), so that the rows of a run
of a few positions (``--position``) meet the same rows of the whole study; prints the spread
and the rows outside the bands of issue 29 (wear 10 %, A_p 3 points) or the given ones.

    python benchmarks/compare_summaries.py REFERENCE.csv OTHER.csv [--wear-pct 10] [--ap-pt 3]

The wear is compared where the reference wore at least ``--min-wear-um`` (default 0.01 µm):
below that a relative figure says nothing. Exit status 0 (a report, not a test)."""
from __future__ import annotations

import argparse

import numpy as np

from micropit_hpc.io.results import ResultsError, load_summary


def read(path: str) -> dict[tuple, dict]:
    """The rows of summary.csv ``path`` (:func:`~micropit_hpc.io.results.load_summary`, which
    names the file when it is not one) by (position, k_lub, body, cycles)."""
    t = load_summary(path)
    cols = ("position", "k_lub_s", "body", "cycles", "Ap_pct", "wear_um")
    return {(int(t["position"][i]), float(t["k_lub_s"][i]), int(t["body"][i]),
             float(t["cycles"][i])): {c: t[c][i] for c in cols} for i in range(t.rows)}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reference")
    ap.add_argument("other")
    ap.add_argument("--wear-pct", type=float, default=10.0)
    ap.add_argument("--ap-pt", type=float, default=3.0)
    ap.add_argument("--min-wear-um", type=float, default=0.01)
    a = ap.parse_args(argv)
    try:
        ref, oth = read(a.reference), read(a.other)
    except ResultsError as e:
        raise SystemExit(f"compare_summaries: {e}") from None
    keys = [k for k in ref if k in oth]
    if not keys:
        raise SystemExit(f"compare_summaries: no (position, k_lub, body, cycles) row of "
                         f"{a.other} is in {a.reference}")
    dap, dw, out = [], [], []
    for k in keys:
        r, o = ref[k], oth[k]
        d_ap = float(o["Ap_pct"]) - float(r["Ap_pct"])
        dap.append(abs(d_ap))
        w_r, w_o = float(r["wear_um"]), float(o["wear_um"])
        d_w = 100.0 * (w_o - w_r) / w_r if w_r >= a.min_wear_um else float("nan")
        if np.isfinite(d_w):
            dw.append(abs(d_w))
        if abs(d_ap) > a.ap_pt or abs(d_w) > a.wear_pct:
            out.append(f"  position {k[0]:>2}, k_lub {k[1]:g} s, "
                       f"body {k[2]} after {k[3] / 1e6:g} M: A_p {float(r['Ap_pct']):.2f}"
                       f" -> {float(o['Ap_pct']):.2f} % ({d_ap:+.2f} pt), wear {w_r:.3f} -> "
                       f"{w_o:.3f} um ({d_w:+.1f} %)")
    dap, dw = np.array(dap), np.array(dw)
    print(f"{len(keys)} rows ({len(dw)} with wear >= {a.min_wear_um} um)")
    print(f"A_p  |d| median {np.median(dap):.2f} pt, max {dap.max():.2f} pt, "
          f"{int((dap > a.ap_pt).sum())} rows > {a.ap_pt:g} pt")
    if dw.size:
        print(f"wear |d| median {np.median(dw):.2f} %, max {dw.max():.1f} %, "
              f"{int((dw > a.wear_pct).sum())} rows > {a.wear_pct:g} %, "
              f"{int((dw > a.wear_pct / 2).sum())} rows > {a.wear_pct / 2:g} %")
    for line in out:
        print(line)


if __name__ == "__main__":
    main()
