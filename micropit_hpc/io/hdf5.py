"""What every HDF5 writer of the package shares: the h5py import guard, the scene as JSON, and
the atomic single-writer file (``*.tmp``, flushed, fsynced, renamed — a crash never leaves a
half-written file under the final name). Parallel checkpoints have their own protocol
(:mod:`micropit_hpc.io.checkpoint`)."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from micropit_hpc.errors import MicropitError

__all__ = ["atomic_h5", "h5py_module", "scene_json"]


def h5py_module():
    """The h5py module, or a MicropitError saying how to install it."""
    try:
        import h5py
    except ImportError:  # pragma: no cover - h5py is part of the Debian stack
        raise MicropitError("writing HDF5 needs h5py (apt-get install python3-h5py-mpi; see "
                            "docs/install.md)") from None
    return h5py


def scene_json(document) -> str:
    """The scene as read, as JSON (TOML dates become ISO strings)."""
    return json.dumps(document, default=str, sort_keys=True)


@contextmanager
def atomic_h5(path: str | Path) -> Iterator:
    """Open ``path.tmp`` for writing by this process alone; on a clean exit flush, fsync and
    rename it to ``path``; on an error remove it. Yields the open ``h5py.File``."""
    h5py = h5py_module()
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with h5py.File(tmp, "w", driver=None) as f:
            yield f
            f.flush()
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
