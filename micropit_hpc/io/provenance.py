"""Provenance of results files: library versions and hashes of the input files.

A result can be traced to the code (``source_commit``), the libraries that computed it
(:func:`library_versions`) and the exact inputs (:func:`input_hashes`: SHA-256 of the scene
file and of every measured map it reads).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import platform
from pathlib import Path

__all__ = ["input_hashes", "library_versions", "sha256_file"]

_MODULES = ("numpy", "scipy", "h5py", "mpi4py", "petsc4py", "pyfftw", "mpi4py_fft",
            "matplotlib")


def library_versions() -> dict[str, str]:
    """{name: version} of Python, the numerical libraries, and the MPI, HDF5, PETSc and FFTW
    libraries underneath ("missing" where a module is not installed)."""
    out = {"python": platform.python_version()}
    for name in _MODULES:
        try:
            mod = importlib.import_module(name)
            out[name] = str(getattr(mod, "__version__", "unknown"))
        except Exception:    # an import can fail in many ways; the file still gets written
            out[name] = "missing"
    try:
        import h5py
        out["hdf5"] = h5py.version.hdf5_version
        out["h5py_mpi"] = str(bool(h5py.get_config().mpi))
    except Exception:
        pass
    try:
        from mpi4py import MPI
        out["mpi_library"] = MPI.Get_library_version().replace("\x00", "").strip(
            ).splitlines()[0]
    except Exception:
        pass
    try:
        from petsc4py import PETSc
        out["petsc"] = ".".join(map(str, PETSc.Sys.getVersion()))
    except Exception:
        pass
    return out


def sha256_file(path: str | Path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def input_hashes(scene) -> dict[str, str]:
    """{absolute path: SHA-256} of the scene file and of the measured maps (``surface.kind =
    "file"``) of both bodies; a file that cannot be read is recorded as "unreadable"."""
    paths = [scene.source]
    for body in (scene.body1, scene.body2):
        if body.surface.kind == "file" and body.surface.file:
            paths.append(body.surface.file)
    out = {}
    for p in paths:
        try:
            out[os.path.abspath(p)] = sha256_file(p)
        except OSError:
            out[os.path.abspath(p)] = "unreadable"
    return out
