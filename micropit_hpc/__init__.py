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
    """The git commit of the package's source, or "" where it is not a git checkout or git is
    missing; written into results files so that a number can be traced to the code that made
    it. Asked once per process (:func:`describe_source`)."""
    return describe_source(Path(__file__).resolve().parent)


def describe_source(directory: Path, paths: tuple[str, ...] = (".",)) -> str:
    """``git describe --always --abbrev=7`` of the checkout holding ``directory``, with
    "-dirty" appended when a tracked file matched by the git pathspecs ``paths`` (relative to
    ``directory``; default: everything under it) differs from that commit. Changes elsewhere
    in the checkout, such as docs or run folders, do not make the package's numbers differ.
    "" where git or the checkout is missing."""
    def git(*args: str) -> str | None:
        try:
            out = subprocess.run(["git", *args], cwd=directory, capture_output=True, text=True,
                                 timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return out.stdout.strip() if out.returncode == 0 else None

    commit = git("describe", "--always", "--abbrev=7")
    if not commit:
        return ""
    changed = git("status", "--porcelain", "--untracked-files=no", "--", *paths)
    return commit + ("-dirty" if changed else "")
