"""``micropit check-env``: can this environment run micropit_hpc in parallel?

Checks the traps of docs/install.md on every rank: the rank count under the launcher, the MPI
library of mpi4py against the launcher's, h5py with the ``mpio`` driver (a real collective
write), petsc4py and its PETSc, pyFFTW (a real transform), and the optional packages. Prints a
table on rank 0 and returns a non-zero exit code naming each problem. Job scripts run it first.
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from micropit_hpc.parallel import launcher_size, world

OK, PROBLEM, WARN = "ok", "PROBLEM", "warning"


@dataclass(frozen=True)
class Check:
    """One line of the report: what was checked, its status, what was found, how to fix it."""

    name: str
    status: str
    detail: str
    fix: str = ""


def _version_of(module) -> str:
    return getattr(module, "__version__", "?")


def check_python() -> Check:
    ok = sys.version_info >= (3, 11)
    return Check("python", OK if ok else PROBLEM,
                 f"{platform.python_version()} ({sys.executable})",
                 "" if ok else "micropit_hpc needs Python >= 3.11 (tomllib)")


def check_numpy() -> Check:
    try:
        import numpy
    except ImportError as e:
        return Check("numpy", PROBLEM, str(e), "install NumPy (Debian: python3-numpy)")
    major = int(numpy.__version__.split(".")[0])
    if major >= 2 and Path("/usr/lib/python3/dist-packages/h5py").exists():
        return Check("numpy", PROBLEM, f"{numpy.__version__} from {Path(numpy.__file__).parent}",
                     "NumPy >= 2 in this environment breaks Debian's compiled modules; "
                     "remove it (pip uninstall numpy) and keep Debian's")
    return Check("numpy", OK, numpy.__version__)


def check_scipy() -> Check:
    try:
        import scipy
    except ImportError as e:
        return Check("scipy", PROBLEM, str(e), "install SciPy (Debian: python3-scipy)")
    return Check("scipy", OK, scipy.__version__)


def _launcher_vendor() -> str | None:
    exe = shutil.which("mpirun") or shutil.which("mpiexec")
    if exe is None:
        return None
    try:
        out = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired):
        return None
    text = (out.stdout + out.stderr).strip()
    return f"{text.splitlines()[0] if text else '?'} ({exe})"


def _same_family(vendor: str, launcher: str) -> bool:
    v, lch = vendor.lower(), launcher.lower()
    families = (("open mpi", ("open mpi", "open-mpi", "openrte")),
                ("mpich", ("hydra", "mpich")),
                ("intel", ("intel",)),
                ("microsoft", ("microsoft",)))
    for name, marks in families:
        if name in v:
            return any(mark in lch for mark in marks)
    return True  # an unknown vendor: nothing to compare


def check_mpi(comm, expect_ranks: int | None) -> list[Check]:
    """mpi4py, the rank count, and the MPI library against the launcher."""
    try:
        from mpi4py import MPI
    except ImportError as e:
        return [Check("mpi4py", PROBLEM, str(e), "install mpi4py built against the site's MPI "
                                                 "(Debian: python3-mpi4py)")]
    vendor = MPI.get_vendor()
    vendor_txt = f"{vendor[0]} {'.'.join(map(str, vendor[1]))}"
    out = [Check("mpi4py", OK, f"{_version_of(sys.modules['mpi4py'])}, library {vendor_txt}")]
    size = comm.size
    expected = launcher_size()
    detail = f"{size} rank{'s' if size != 1 else ''}"
    if expected is not None and expected != size:
        out.append(Check("ranks", PROBLEM, f"{detail}, but the launcher started {expected}",
                         "the launcher and mpi4py use different MPI libraries: each process is "
                         "a singleton. Use the mpirun of the MPI that mpi4py was built with"))
    elif expect_ranks is not None and size != expect_ranks:
        out.append(Check("ranks", PROBLEM, f"{detail}, expected {expect_ranks}",
                         f"start with mpirun -n {expect_ranks}"))
    else:
        out.append(Check("ranks", OK, detail + (" (no launcher)" if expected is None else "")))
    launcher = _launcher_vendor()
    if launcher is None:
        out.append(Check("launcher", WARN, "no mpirun/mpiexec on PATH",
                         "fine under srun; otherwise put the MPI's bin directory on PATH"))
    elif _same_family(vendor[0], launcher):
        out.append(Check("launcher", OK, launcher))
    else:
        out.append(Check("launcher", PROBLEM, f"{launcher} but mpi4py uses {vendor_txt}",
                         "mixing MPI libraries starts N singletons silently; use the matching "
                         "mpirun or rebuild mpi4py against this MPI"))
    return out


def check_h5py() -> Check:
    """h5py with the MPI driver, proven by a small collective write and read-back."""
    os.environ.setdefault("H5PY_ALWAYS_USE_MPI", "1")  # Debian: pick the MPI build (trap 2)
    try:
        import h5py
    except ImportError as e:
        return Check("h5py", PROBLEM, str(e), "install h5py built against parallel HDF5 "
                                              "(Debian: python3-h5py-mpi)")
    where = Path(h5py.__file__).parent
    if not h5py.get_config().mpi:
        return Check("h5py", PROBLEM, f"{h5py.__version__} without MPI ({where})",
                     "a serial h5py (e.g. a pip wheel) shadows the MPI build: pip uninstall "
                     "h5py in this environment, or set H5PY_ALWAYS_USE_MPI=1 for Debian's")
    return Check("h5py", OK, f"{h5py.__version__}, mpio driver ({where})")


def mpio_roundtrip(comm) -> str | None:
    """Every rank writes its rank number into one shared file collectively; returns an error
    text or None. Collective: call on all ranks, only after all ranks imported h5py."""
    import h5py
    import numpy as np

    tmpdir = comm.bcast(tempfile.mkdtemp(prefix="micropit-check-") if comm.rank == 0 else None)
    path = os.path.join(tmpdir, "check.h5")
    error = None
    try:
        with h5py.File(path, "w", driver="mpio", comm=comm) as f:
            dset = f.create_dataset("ranks", (comm.size,), dtype="i8")
            with dset.collective:
                dset[comm.rank] = comm.rank
        comm.Barrier()
        with h5py.File(path, "r", driver="mpio", comm=comm) as f:
            got = f["ranks"][...]
        if not np.array_equal(got, np.arange(comm.size)):
            error = f"read back {got.tolist()}"
    except Exception as e:  # report any HDF5 failure as a problem, not a crash
        error = f"{type(e).__name__}: {e}"
    comm.Barrier()
    if comm.rank == 0:
        shutil.rmtree(tmpdir, ignore_errors=True)
    return error


def check_petsc(comm) -> Check:
    try:
        import petsc4py

        petsc4py.init(sys.argv[:1])
        from petsc4py import PETSc
    except ImportError as e:
        return Check("petsc4py", PROBLEM, str(e),
                     "install petsc4py (Debian: python3-petsc4py) and point Python at it: set "
                     "PETSC_DIR=/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real or add a "
                     ".pth file (scripts/setup.sh does)")
    version = ".".join(map(str, PETSc.Sys.getVersion()))
    psize = PETSc.COMM_WORLD.getSize()
    if psize != comm.size:
        return Check("petsc4py", PROBLEM, f"PETSc {version} sees {psize} ranks, mpi4py {comm.size}",
                     "petsc4py and mpi4py are built against different MPI libraries")
    return Check("petsc4py", OK, f"{_version_of(petsc4py)}, PETSc {version}")


def check_pyfftw() -> Check:
    try:
        import numpy as np
        import pyfftw
    except ImportError as e:
        return Check("pyfftw", PROBLEM, str(e), "install pyFFTW (Debian: python3-pyfftw)")
    a = pyfftw.empty_aligned((30, 32), dtype="float64")
    a[...] = np.random.default_rng(0).standard_normal(a.shape)
    plan = pyfftw.builders.rfft2(a, planner_effort="FFTW_ESTIMATE")
    err = float(np.max(np.abs(plan() - np.fft.rfft2(a))))
    if err > 1e-10:
        return Check("pyfftw", PROBLEM, f"{pyfftw.__version__}: rfft2 differs from numpy by {err}",
                     "the FFTW library is broken")
    return Check("pyfftw", OK, f"{pyfftw.__version__}, rfft2 verified")


def check_optional(name: str, module: str, use: str) -> Check:
    try:
        mod = __import__(module)
    except ImportError:
        return Check(name, WARN, "not installed", f"needed for {use}")
    return Check(name, OK, _version_of(mod))


def run_checks(comm, expect_ranks: int | None = None) -> list[Check]:
    """All checks on this rank (collective: every rank must call it)."""
    checks = [check_python(), check_numpy(), check_scipy()]
    checks += check_mpi(comm, expect_ranks)
    h5 = check_h5py()
    # the collective write only if every rank has a working MPI h5py (else it would hang)
    if all(comm.allgather(h5.status == OK)):
        error = mpio_roundtrip(comm)
        if error:
            h5 = Check("h5py", PROBLEM, f"collective mpio write failed: {error}",
                       "check the parallel HDF5 installation and the file system (MPI-IO)")
        else:
            h5 = Check("h5py", OK, h5.detail + f", collective write by {comm.size} ranks")
    checks.append(h5)
    checks.append(check_petsc(comm))
    checks.append(check_pyfftw())
    checks.append(check_optional("mpi4py-fft", "mpi4py_fft", "patches over several ranks"))
    checks.append(check_optional("matplotlib", "matplotlib", "plots"))
    return checks


def format_report(per_rank: list[list[Check]]) -> tuple[str, list[str]]:
    """The table (rank 0's view) and one line per problem on any rank."""
    first = per_rank[0]
    width = max(len(c.name) for c in first)
    lines = [f"micropit check-env: {len(per_rank)} rank(s)", ""]
    lines += [f"  {c.name:<{width}}  {c.status:<7}  {c.detail}" for c in first]
    problems = []
    for rank, checks in enumerate(per_rank):
        for c in checks:
            if c.status == PROBLEM:
                problems.append(f"{c.name} (rank {rank}): {c.detail} -- {c.fix}")
    warnings = [f"{c.name}: {c.detail} -- {c.fix}" for c in first if c.status == WARN]
    if warnings:
        lines += ["", "warnings:"] + [f"  - {w}" for w in warnings]
    if problems:
        lines += ["", f"{len(problems)} problem(s):"] + [f"  - {p}" for p in problems]
    else:
        lines += ["", "environment OK"]
    return "\n".join(lines), problems


def main(expect_ranks: int | None = None) -> int:
    comm = world()
    checks = run_checks(comm, expect_ranks)
    per_rank = comm.allgather(checks)
    text, problems = format_report(per_rank)
    if comm.rank == 0:
        print(text, flush=True)
    return 1 if problems else 0
