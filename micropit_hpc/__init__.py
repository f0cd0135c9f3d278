"""micropit_hpc: MPI-parallel prediction of micropitting on rough, lubricated rolling-sliding
contacts.

Implements and extends Morales-Espejel, Rycerz & Kadiric, Wear 398-399 (2018) 99-115.
SI units everywhere inside the package; engineering units only in scene-file keys and reports.
"""

import functools
import subprocess
from pathlib import Path

__version__ = "0.1.0"


@functools.cache
def source_commit() -> str:
    """The git commit of the package's source (``git describe --always --dirty``), or "" where
    it is not a git checkout or git is missing; written into results files so that a number can
    be traced to the code that made it. Asked once per process."""
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty", "--abbrev=7"],
                             cwd=Path(__file__).resolve().parent, capture_output=True,
                             text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""
