"""What several test modules share: small scenes, the environment of a child process, the
comparison of two runs' results, rough gaps, rounding bounds. Import from here
(``from helpers import tiny_doc, write_scene``), never from another test module.

Markers (setup.cfg): ``mpi`` (runs under ``mpirun -n 2 ... --with-mpi``) and ``slow`` (starts a
whole run, ``mpirun`` or a job script: ``pytest -m "not slow"`` is the quick loop).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenes"
VALIDATION = ROOT / "validation"
EPS = np.finfo(float).eps


def read_table(name: str) -> list[dict[str, str]]:
    """A validation table of the paper (validation/*.csv) as a list of rows."""
    import csv

    with open(VALIDATION / name, newline="") as fh:
        return list(csv.DictReader(fh))

# ---- scenes ------------------------------------------------------------------------------------


def tiny_doc(slide_roll=(0.0, 0.3), k_lub=(0.0,)):
    """The tiny disc-rig scene (32² window, 8 steps, 6 layers, 2 M cycles in 1 M blocks) as a
    dict: the scene of most life, run and restart tests."""
    return {
        "study": {"name": "tiny"},
        "disc": {"p0_GPa": 1.1, "u_mean_m_s": 1.1, "slide_roll": list(slide_roll),
                 "radius1_x_mm": 6.0, "radius2_x_mm": 27.075},
        "body1": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.16,
                  "surface": {"acf": "gaussian", "corr_x_um": 15.0}},
        "body2": {"E_GPa": 210.0, "nu": 0.3, "Rq_um": 0.21,
                  "surface": {"acf": "gaussian", "corr_x_um": 15.0}},
        "lubricant": {"eta0_mPas": 3.1, "alpha_pv_1_per_GPa": 14.0, "eyring_stress_MPa": 5.0},
        "film": {"hc_um": 0.037},
        # the rule that raises the steps with the slip (docs/model.md §4) held off: λ_c/16
        # would ask 45 steps at |S| = 0.3 here; test_cycle.py tests the rule
        "window": {"n": 32, "steps": 8, "steps_per_peak_spacing": 0.25},
        "stress": {"layers": 6},
        "wear": {"k_lub_s": list(k_lub)},
        # the life-loop tests check Miner, wear, pits, restarts and invariances, not how finely
        # the running-in is resolved: the previous default split and the relaxed wear keep
        # them quick (the implicit wear has its own tests, test_implicit_wear.py, and the
        # run tests on scenes/quick.toml run it)
        "life": {"cycles_M": 2.0, "block_M": 1.0, "max_splits": 4,
                 "wear_integration": "relaxed"},
    }


def process_averaged(cycle, *maps):
    """Each material-frame map averaged over ``cycle``'s process area as the criterion sees it
    (its discrete Gaussian, ``fatigue.process_length_um`` = ℓ; the map itself for ℓ = 0):
    the surface stresses the cycle assembles are σ_zz(0) = −p̃, σ_xz(0) = −q̃ of these."""
    g = cycle.process_transfer(slice(None))
    if g is None:
        return maps
    return tuple(np.fft.irfft2(np.fft.rfft2(m) * g, s=m.shape) for m in maps)


def write_scene(path, doc):
    """Write the scene dict ``doc`` (tables, one level of sub-tables) as TOML to ``path``."""
    def val(v):
        return json.dumps(v) if not isinstance(v, list) else "[" + ", ".join(map(str, v)) + "]"
    lines = []
    for table, keys in doc.items():
        sub = {k: v for k, v in keys.items() if isinstance(v, dict)}
        lines.append(f"[{table}]")
        lines += [f"{k} = {val(v)}" for k, v in keys.items() if not isinstance(v, dict)]
        for name, t in sub.items():
            lines.append(f"[{table}.{name}]")
            lines += [f"{k} = {val(v)}" for k, v in t.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


#: A small window for the shipped gear scenes (:func:`gear_scene`).
SMALL = """
[window]
n = 32
steps = 4
steps_per_peak_spacing = 0.25
[stress]
layers = 4
"""


def gear_scene(tmp_path, base="gear_z23", extra=SMALL, drop=(), name="small"):
    """A copy of scenes/``base``.toml with the lines in ``drop`` removed and ``extra``
    appended (by default the small window :data:`SMALL`)."""
    text = (SCENES / f"{base}.toml").read_text()
    for line in drop:
        text = text.replace(line, "")
    path = tmp_path / f"{base}_{name}.toml"
    path.write_text(text + extra)
    return path


# ---- the life loop -----------------------------------------------------------------------------


def evaluate(cycle, state):
    """One load cycle on the surfaces the contact sees in ``state`` (as run_block does)."""
    from micropit_hpc.life import contact_surfaces

    return cycle.evaluate(*contact_surfaces(state, cycle.grid, cycle.scene.life.pit_contact))


def fake_result(shape, nz, d_rate, w_rate):
    """A load cycle's result with uniform damage and wear rates (no contact solved)."""
    from micropit_hpc.cycle import BodyCycle, CycleResult
    from micropit_hpc.wear import WearRate

    bodies = tuple(BodyCycle(damage_rate=np.full((nz, *shape), d_rate),
                             wear=WearRate(np.zeros(shape), np.full(shape, w_rate),
                                           np.zeros(shape)),
                             tau_rough=np.zeros((nz, *shape)),
                             tau_smooth=np.zeros(nz), n_micro=0.0, lam_c=np.inf)
                   for _ in range(2))
    return CycleResult(bodies=bodies, phi=0.0, solid_fraction=0.0, steps=1, wall_s=0.0)


# ---- contact -----------------------------------------------------------------------------------

E_STEEL, NU_STEEL = 210e9, 0.3
E_PRIME = E_STEEL / (1 - NU_STEEL**2)   # 2/E' = Σ(1 − ν²)/E for two steel bodies


def rough_gap(seed=3, n=128):
    """A band-limited random gap on a small window (no surfaces package needed): (grid, gap)."""
    from micropit_hpc.spectral import Grid

    g = Grid(n, n, 2e-4, 2e-4)
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft2(rng.standard_normal(g.shape))
    spec *= np.exp(-(g.kappa * 8e-6) ** 2)
    z = np.fft.irfft2(spec, s=g.shape)
    z *= 1e-6 / z.std()
    return g, z - z.min()


# ---- rounding ----------------------------------------------------------------------------------


def sum_bound(terms) -> float:
    """The most two summation orders of ``terms`` can differ by: each sum's error is at most
    γ_(n−1)·Σ|x| ≤ (n−1)·ε·Σ|x| (Higham, *Accuracy and Stability*, §4.2), so two orders differ
    by at most twice that. Depends on the data, not on the CPU's vector width."""
    a = np.abs(np.asarray(terms, dtype=float)).ravel()
    return 2.0 * max(a.size - 1, 1) * EPS * math.fsum(a)


def assert_sum_close(got, ref, magnitudes, what="", exact=None):
    """``got`` and ``ref`` are the same sum added in two orders (and with terms that may differ
    by their own round-off): within :func:`sum_bound` of ``magnitudes``, a bound on each term's
    size; and, when ``exact`` (the terms) is given, both within it of ``math.fsum(exact)``."""
    bound = sum_bound(magnitudes)
    assert abs(got - ref) <= bound, (what, got, ref, bound)
    if exact is not None:
        total = math.fsum(np.asarray(exact, dtype=float).ravel())
        for x in (got, ref):
            assert abs(x - total) <= bound, (what, x, total, bound)


def assert_rounding_close(got, ref, scale, ulps=4.0, what=""):
    """Elementwise results of the same formula evaluated two ways (e.g. with and without fused
    multiply-adds): within ``ulps`` units of round-off of ``scale``, the sum of the magnitudes
    of the operands (not of the result, which may cancel)."""
    got, ref = np.asarray(got), np.asarray(ref)
    tol = ulps * EPS * np.asarray(scale)
    bad = np.abs(got - ref) > tol
    assert not bad.any(), (what, int(bad.sum()), float(np.max(np.abs(got - ref) - tol)))


# ---- child processes ---------------------------------------------------------------------------


def environment(**extra):
    """The environment of a child ``micropit`` or ``mpirun`` started by a test: no leftover
    MPI rank variables of this process, the repository and tests/ on the path, unbuffered
    output, parallel HDF5, Open MPI allowed to oversubscribe (and to run as root)."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OMPI_COMM_WORLD", "PMIX_", "PMI_"))}
    env["PYTHONPATH"] = f"{ROOT}{os.pathsep}{ROOT / 'tests'}"
    env["PYTHONUNBUFFERED"] = "1"
    env["H5PY_ALWAYS_USE_MPI"] = "1"
    env.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
    if os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    env.update(extra)
    return env


#: A hang of :func:`mpirun_fault` is killed after this many seconds; a clean failure takes a
#: few seconds (a hang guard, not a timing claim).
HANG_LIMIT_S = 100


def mpirun_fault(args, fault=("none", 0)):
    """(exit code, stderr) of ``mpirun -n 2`` running micropit with ``fault``
    (tests/fault_run.py); a hang fails the test."""
    cmd = ["mpirun", "-n", "2", sys.executable, str(ROOT / "tests" / "fault_run.py"),
           fault[0], str(fault[1]), *map(str, args)]
    try:
        p = subprocess.run(cmd, env=environment(), capture_output=True, text=True,
                           timeout=HANG_LIMIT_S)
    except subprocess.TimeoutExpired as e:
        pytest.fail(f"hang: {cmd} still running after {HANG_LIMIT_S} s; stderr: {e.stderr}")
    return p.returncode, p.stderr


def error_lines(err: str) -> list[str]:
    """The ``micropit: error:`` lines of a command's stderr."""
    return [ln for ln in err.splitlines() if ln.startswith("micropit: error:")]


def wait_for_text(path: Path, text: str, proc=None, timeout_s: float = 120.0) -> bool:
    """Wait until ``text`` appears in the file ``path`` (or ``proc`` ends); True if it did."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            if text in Path(path).read_text(errors="replace"):
                return True
        except FileNotFoundError:
            pass
        if proc is not None and proc.poll() is not None:
            return text in Path(path).read_text(errors="replace")
        time.sleep(0.05)
    return False


# ---- results -----------------------------------------------------------------------------------


def results_differ(a: Path, b: Path) -> list[str]:
    """Datasets of results.h5 that differ (wall times excepted), and summary.csv."""
    import h5py

    out = []
    if (a / "summary.csv").read_text() != (b / "summary.csv").read_text():
        out.append("summary.csv")
    with h5py.File(a / "results.h5", "r") as fa, h5py.File(b / "results.h5", "r") as fb:
        names = []
        fa.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            if n.endswith("wall_s"):
                continue
            if n not in fb:
                out.append(n)
                continue
            x, y = fa[n][()], fb[n][()]
            if not np.array_equal(x, y, equal_nan=np.asarray(x).dtype.kind == "f"):
                out.append(n)
        assert len(names) > 30
    return out


def _solver() -> dict:
    from micropit_hpc.scene import LubricationSpec

    return {"tol": LubricationSpec().tol, "max_iter": LubricationSpec().max_iter}


#: The scene's contact-solver settings (lubrication.tolerance and max_iterations).
SOLVER = _solver()


def mixed_settings(eta0: float, alpha: float, p_lim: float = math.inf, **lubrication) -> dict:
    """The mixed model's settings: the scene's [lubrication] defaults (or ``lubrication``),
    an oil of η0 and α with Eyring stress 5 MPa, and the pressure cap."""
    from micropit_hpc.scene import Lubricant, LubricationSpec

    return {"lubrication": LubricationSpec(**lubrication),
            "lubricant": Lubricant(eta0=eta0, alpha_pv=alpha, tau0=5e6), "p_lim": p_lim}


def random_pair(n=64, seed=7):
    """Two band-limited random surfaces of R_q 0.3 µm on a 0.3 mm window: (grid, [z1, z2])."""
    from micropit_hpc.spectral import Grid

    g = Grid(n, n, 3e-4, 3e-4)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(2):
        s = np.fft.rfft2(rng.standard_normal(g.shape)) * np.exp(-(g.kappa * 1.5e-5) ** 2)
        z = np.fft.irfft2(s, s=g.shape)
        out.append((z - z.mean()) * 0.3e-6 / z.std())
    return g, out


def mixed_model(g, h_mean, eta0=0.05, S=0.3):
    """The mixed model of a line contact at slide–roll ratio ``S`` on grid ``g``."""
    from micropit_hpc.lubrication.mixed import MixedLubrication

    u1, u2 = 2.0 * (1 + S / 2), 2.0 * (1 - S / 2)
    return MixedLubrication(g, geometry="line", load=3e5, R=0.01, b=2e-4, u1=u1, u2=u2,
                            h_mean=h_mean, E_prime=E_PRIME, **mixed_settings(eta0, 20e-9, 4.2e9))


def load_benchmark(name: str):
    """The module ``benchmarks/<name>.py`` (benchmarks are scripts, not a package), with its
    folder on ``sys.path`` for its sibling modules (``table``, ``bench_wear_convergence``)."""
    import importlib.util

    if str(ROOT / "benchmarks") not in sys.path:
        sys.path.insert(0, str(ROOT / "benchmarks"))
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
