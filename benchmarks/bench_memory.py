"""Peak memory of one load-cycle evaluation, whole-depth against streamed stresses
(docs/performance.md "Streamed stresses").

Each case runs in a fresh process (the peak resident size, VmHWM, only grows): the tiny disc
scene of the tests (mixed lubrication, slide-to-roll 0.3) on an n² window with the default
15 depth layers and 20 time steps, one rank. The child builds the cycle and solves nothing,
reads its resident size (``base``), evaluates one load cycle (``PositionCycle.evaluate``:
contact at 20 steps, stresses, Dang Van, damage and wear of both bodies) and reads VmHWM
(``peak``) and ``resource.getrusage``'s ru_maxrss. ``peak − base`` over the grid points is the
evaluation's own transient in bytes per point. The modes:

* ``streamed``: the code as it is, chunks of ``PositionCycle.chunk_layers()`` layers
  (``STRESS_CHUNK_BYTES`` per rank);
* ``layer``: one layer per chunk (budget 1 byte);
* ``whole``: one chunk of all layers (budget ∞): the whole history at once, as before the
  streaming but written into one buffer;
* the code before the streaming (``np.stack`` of the m whole-depth histories) is measured by
  running this script with ``PYTHONPATH`` on a checkout of that commit: the child then reports
  mode ``stacked`` (its ``PositionCycle`` has no ``chunk_layers``).

``--run`` measures instead the peak of a whole ``micropit run`` of the same scene (one item,
one block of 1 M cycles, ``life.max_splits = 1``) against the estimate it prints
(micropit_hpc/estimate.py).

    PYTHONPATH=. .venv/bin/python benchmarks/bench_memory.py [--sizes 128 256 512]
        [--modes streamed,layer,whole] [--contact mixed|dry|smooth] [--run]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")    # one core: before numpy is imported

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

MIB = 2.0 ** 20


def scene_doc(n: int, steps: int = 20, layers: int = 15, contact: str = "mixed") -> dict:
    """The tiny disc scene of tests/test_life.py on an n² window (``contact = "dry"``: its
    roughness in dry contact, ``lubrication.model = "dry"``)."""
    doc = {
        "study": {"name": f"mem{n}"},
        "disc": {"p0_GPa": 1.1, "u_mean_m_s": 1.1, "slide_roll": [0.3],
                 "radius1_x_mm": 6.0, "radius2_x_mm": 27.075},
        "body1": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.16,
                  "surface": {"acf": "gaussian", "corr_x_um": 15.0}},
        "body2": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.21,
                  "surface": {"acf": "gaussian", "corr_x_um": 15.0}},
        "lubricant": {"eta0_mPas": 3.1, "alpha_pv_1_per_GPa": 14.0, "eyring_stress_MPa": 5.0},
        "film": {"hc_um": 0.037},
        "window": {"n": n, "steps": steps},
        "stress": {"layers": layers},
        "wear": {"k_lub_s": [1e-11]},
        "life": {"cycles_M": 1.0, "block_M": 1.0, "max_splits": 1},
    }
    if contact != "mixed":
        doc["lubrication"] = {"model": contact}
    return doc


def status_mib(key: str) -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return float(line.split()[1]) / 1024.0
    return math.nan


def child(n: int, mode: str, contact: str) -> None:
    from micropit_hpc.conditions import contact_study
    from micropit_hpc.cycle import PositionCycle
    from micropit_hpc.scene import scene_from_dict

    scene = scene_from_dict(scene_doc(n, contact=contact), f"mem{n}.toml")
    cyc = PositionCycle(contact_study(scene), 1)
    streamed = hasattr(cyc, "chunk_layers")
    budget = {"streamed": None, "layer": 1.0, "whole": math.inf}[mode]
    if budget is not None:
        cyc.stress_chunk_bytes = budget
    size = cyc.chunk_layers() if streamed else cyc.z.size
    base = status_mib("VmRSS")
    t0 = time.perf_counter()
    res = cyc.evaluate(cyc.surfaces)
    wall = time.perf_counter() - t0
    peak = status_mib("VmHWM")
    maxrss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    tau = max(float(b.tau_rough.max()) for b in res.bodies)
    print(json.dumps({"n": n, "mode": mode if streamed else "stacked", "chunk": size,
                      "layers": int(cyc.z.size), "steps": cyc.steps, "base_mib": base,
                      "peak_mib": peak, "maxrss_mib": maxrss, "wall_s": wall,
                      "tau_max": tau}))


def run_case(n: int, mode: str, contact: str) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", str(n), mode, contact],
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise SystemExit(f"case {n}² {mode} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_micropit(n: int) -> dict:
    """Peak RSS of a whole `micropit run` (one item, one block) against its printed estimate."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"mem{n}.toml"
        path.write_text(_toml(scene_doc(n)))
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "micropit_hpc", "run", str(path), "--out",
                              str(Path(tmp) / "out")], capture_output=True, text=True,
                             check=False, cwd=tmp)   # not the checkout: PYTHONPATH decides
        wall = time.perf_counter() - t0
    if out.returncode != 0:
        raise SystemExit(f"micropit run {n}² failed:\n{out.stderr}")
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    line = next(ln for ln in out.stderr.splitlines() if "estimate:" in ln)
    est = float(line.split("~")[1].split(" GiB per rank")[0]) * 1024.0
    return {"n": n, "peak_mib": peak, "estimate_mib": est, "wall_s": wall}


def _toml(doc: dict) -> str:
    """The scene dict as TOML (tables of scalars, lists and one level of sub-tables)."""
    def val(v):
        return json.dumps(v) if not isinstance(v, list) else "[" + ", ".join(map(str, v)) + "]"
    lines = []
    for table, keys in doc.items():
        lines.append(f"[{table}]")
        lines += [f"{k} = {val(v)}" for k, v in keys.items() if not isinstance(v, dict)]
        for name, sub in keys.items():
            if isinstance(sub, dict):
                lines.append(f"[{table}.{name}]")
                lines += [f"{k} = {val(v)}" for k, v in sub.items()]
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 256, 512])
    ap.add_argument("--modes", default="streamed,layer,whole",
                    help="comma-separated: streamed, layer, whole")
    ap.add_argument("--run", action="store_true",
                    help="peak of a whole `micropit run` against its estimate instead")
    ap.add_argument("--contact", default="mixed", choices=("mixed", "dry", "smooth"),
                    help="lubrication.model of the scene (default: mixed, the scene's own)")
    ap.add_argument("--child", nargs=3, metavar=("N", "MODE", "CONTACT"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(int(args.child[0]), args.child[1], args.child[2])
        return
    from micropit_hpc import source_commit

    print(f"# {datetime.date.today().isoformat()}, commit {source_commit() or 'unknown'}, "
          f"one rank, 15 layers, 20 steps, tiny disc scene ({args.contact})")
    if args.run:
        print("| grid | peak RSS [MiB] | estimate [MiB] | estimate / peak | wall [s] |")
        print("|---|---|---|---|---|")
        for n in args.sizes:   # in increasing size: RUSAGE_CHILDREN keeps the largest
            r = run_micropit(n)
            print(f"| {n}² | {r['peak_mib']:.0f} | {r['estimate_mib']:.0f} | "
                  f"{r['estimate_mib'] / r['peak_mib']:.2f} | {r['wall_s']:.1f} |", flush=True)
        return
    print("| grid | mode | layers per chunk | base [MiB] | peak [MiB] | peak − base [MiB] | "
          "B per point | wall [s] | max τ_DV [Pa] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for mode in args.modes.split(","):
            r = run_case(n, mode, args.contact)
            d = r["peak_mib"] - r["base_mib"]
            print(f"| {n}² | {r['mode']} | {r['chunk']} | {r['base_mib']:.0f} | "
                  f"{r['peak_mib']:.0f} | {d:.0f} | {d * MIB / n ** 2:.0f} | "
                  f"{r['wall_s']:.1f} | {r['tau_max']:.17g} |", flush=True)


if __name__ == "__main__":
    main()
