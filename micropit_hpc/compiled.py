"""Optional compiled kernels (Numba): which implementation a kernel runs, and their lazy import.

Each compiled kernel module (``lubrication/_dry_numba.py``, ``lubrication/_mixed_numba.py``,
``mechanics/_halfspace_numba.py``) needs Numba (Debian's ``python3-numba``, optional:
docs/install.md). Its NumPy counterpart in the module that uses it is the reference the tests
hold it against. A kernel's implementation is chosen by name, ``"auto"`` (compiled where Numba
can be imported, else NumPy), ``"numba"`` or ``"numpy"``; the Dang Van kernel keeps its own
switch (:mod:`micropit_hpc.fatigue.dangvan`).
"""

from __future__ import annotations

import importlib
import warnings

__all__ = ["KERNELS", "compiled_module", "resolve"]

#: The names a kernel choice may take.
KERNELS = ("auto", "numba", "numpy")

_loaded: dict[str, object] = {}      # module name -> the module, or False once its import failed


def compiled_module(name: str):
    """The compiled kernel module ``micropit_hpc.<name>``, or None where Numba cannot be
    imported (silently) or fails (with one RuntimeWarning). The first outcome is kept."""
    mod = _loaded.get(name)
    if mod is None:
        try:
            mod = importlib.import_module(f"micropit_hpc.{name}")
        except ModuleNotFoundError:                 # no Numba: the NumPy path
            mod = False
        except Exception as err:                    # a broken Numba, no writable cache, ...
            warnings.warn(f"{name}: the compiled kernel is not available ({err!r}); using the "
                          "NumPy path", RuntimeWarning, stacklevel=3)
            mod = False
        _loaded[name] = mod
    return mod or None


def resolve(kernel: str, name: str, who: str):
    """The compiled module to run for the choice ``kernel`` (one of :data:`KERNELS`), or None
    for the NumPy path. ``"numba"`` without Numba raises ImportError naming ``who``."""
    if kernel not in KERNELS:
        raise ValueError(f"{who}: kernel must be one of {KERNELS}, got {kernel!r}")
    if kernel == "numpy":
        return None
    mod = compiled_module(name)
    if mod is None and kernel == "numba":
        raise ImportError(f"{who}: kernel='numba' needs Numba (python3-numba; docs/install.md)")
    return mod
