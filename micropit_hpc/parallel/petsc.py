"""Optional PETSc: the options database, ``-log_view`` stages and events (docs/hpc.md §2).

Everything here works without petsc4py: :func:`init_petsc` then returns False, :func:`stage`
and :func:`event` do nothing, and :func:`option` reads the ``-micropit_*`` options from the
arguments given to :func:`init_petsc` with a small parser of its own. PETSc is used only after
:func:`init_petsc` succeeded, so importing this module never initialises PETSc.

Debian installs petsc4py under ``$PETSC_DIR/lib/python3/dist-packages``; the venv of
``scripts/setup.sh`` has a ``.pth`` file for it (docs/hpc.md §1 trap 3).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

PREFIX = "micropit_"
"""Options of this package start with ``-micropit_``; :func:`options_left_warning` checks them."""

_PETSc = None  # the petsc4py.PETSc module once init_petsc() succeeded
_stages: dict[str, object] = {}
_events: dict[str, object] = {}
_fallback: dict[str, str] = {}  # -name value pairs from init_petsc() when PETSc is missing
_queried: set[str] = set()  # option names asked for through option()

#: The code's events, registered in this order on every rank by :func:`init_petsc`. PETSc's
#: ``-log_view`` reduces an event over the ranks by its registration index, and events made
#: at first use were registered in the order each rank first met them: in the 33-item gear
#: study rank 0's first item has no wear and rank 1's has, so ``implicit_wear`` and
#: ``apply_cycles`` were reported under each other's names (max/min ratios of 400+).
EVENTS = ("contact", "stresses", "dang_van", "dang_van_macro", "damage_rate", "wear_rate",
          "implicit_wear", "apply_cycles")


def _parse(argv: list[str]) -> dict[str, str]:
    """``-name value`` / ``-name`` pairs as PETSc reads them (a flag's value is ``""``)."""
    out: dict[str, str] = {}
    i = 0
    while i < len(argv):
        a = argv[i]
        if a.startswith("-") and len(a) > 1 and not _is_number(a):
            nxt = argv[i + 1] if i + 1 < len(argv) else None
            if nxt is not None and (not nxt.startswith("-") or _is_number(nxt)):
                out[a.lstrip("-")] = nxt
                i += 2
                continue
            out[a.lstrip("-")] = ""
        i += 1
    return out


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def init_petsc(argv: list[str]) -> bool:
    """Initialise PETSc with the options ``argv`` (e.g. ``["-log_view", "-options_left"]``).

    Returns False, and keeps the ``-micropit_*`` options for :func:`option`, when petsc4py
    cannot be imported. Call it once, early, after MPI is initialised (mpi4py) and before
    any other use of PETSc; if PETSc was already initialised the options are inserted into
    its database (``-log_view`` then starts logging from here).
    """
    global _PETSc
    argv = [str(a) for a in argv if str(a)]
    _fallback.clear()
    _fallback.update(_parse(argv))
    try:
        import petsc4py
    except ImportError:
        return False
    if "petsc4py.PETSc" in sys.modules:
        from petsc4py import PETSc

        if argv:
            PETSc.Options().insertString(" ".join(argv))
            if "log_view" in _fallback and not PETSc.Log.isActive():
                PETSc.Log.begin()
    else:
        petsc4py.init(argv)
        from petsc4py import PETSc
    _PETSc = PETSc
    for name in EVENTS:
        if name not in _events:
            _events[name] = PETSc.Log.Event(name)
    return True


def petsc():
    """The ``petsc4py.PETSc`` module after a successful :func:`init_petsc`, else None."""
    return _PETSc


def require_petsc(what: str):
    """The ``petsc4py.PETSc`` module (initialised with no options if nobody did yet), or a
    MicropitError saying that ``what`` needs it."""
    if _PETSc is None and not init_petsc([]):
        from micropit_hpc.errors import MicropitError

        raise MicropitError(f"{what} needs petsc4py (Debian: python3-petsc4py with PETSC_DIR "
                            "set or the venv's .pth file; scripts/setup.sh, docs/install.md "
                            "trap 3)")
    return _PETSc


@contextmanager
def _logged(kind: str, name: str, table: dict, enter: str, leave: str) -> Iterator[None]:
    """Around the block: ``PETSc.Log.<kind>(name)`` (made once per name, kept in ``table``),
    its ``enter`` method before and ``leave`` after; nothing without PETSc."""
    if _PETSc is None:
        yield
        return
    obj = table.get(name)
    if obj is None:
        obj = table[name] = getattr(_PETSc.Log, kind)(name)
    getattr(obj, enter)()
    try:
        yield
    finally:
        getattr(obj, leave)()


def stage(name: str):
    """A ``PETSc.Log.Stage`` named ``name`` (one per name) around the block; no-op without
    PETSc. Stages are the sections of the ``-log_view`` profile."""
    return _logged("Stage", name, _stages, "push", "pop")


def event(name: str):
    """A ``PETSc.Log.Event`` named ``name`` (one per name) around the block; no-op without
    PETSc."""
    return _logged("Event", name, _events, "begin", "end")


def option(name: str, default, type=None):
    """The value of option ``-name`` as ``type`` (int, float, bool or str; default: the type
    of ``default``), or ``default`` when it is not set. Reads the PETSc options database,
    or without PETSc the arguments given to :func:`init_petsc`. A bool option given without
    a value is True."""
    key = name.lstrip("-")
    _queried.add(key)
    kind = type if type is not None else (bool if isinstance(default, bool)
                                          else default.__class__ if default is not None
                                          else str)
    if _PETSc is not None:
        opts = _PETSc.Options()
        if not opts.hasName(key):
            return default
        getter = {int: opts.getInt, float: opts.getReal, bool: opts.getBool}.get(kind)
        if getter is not None:
            return getter(key)
        return opts.getString(key)
    if key not in _fallback:
        return default
    text = _fallback[key]
    try:
        if kind is bool:
            if text.lower() in ("", "1", "true", "yes", "on"):
                return True
            if text.lower() in ("0", "false", "no", "off"):
                return False
            raise ValueError(text)
        return kind(text)
    except ValueError:
        from micropit_hpc.errors import MicropitError

        raise MicropitError(f"option -{key} {text}: not a valid {kind.__name__}") from None


def options_left(prefix: str = PREFIX) -> list[str]:
    """The ``-<prefix>*`` options that were set but never asked for through :func:`option`."""
    given = _PETSc.Options().getAll() if _PETSc is not None else _fallback
    return sorted(k for k in given if k.startswith(prefix) and k not in _queried)


def options_left_warning(comm=None, prefix: str = PREFIX, stream=None) -> list[str]:
    """At the end of a run: warn (rank 0, on ``stream``, default stderr) about each
    ``-<prefix>*`` option that was never used (likely a typo). Returns them on every rank."""
    left = options_left(prefix)
    if left and (comm is None or comm.rank == 0):
        out = sys.stderr if stream is None else stream
        for k in left:
            out.write(f"warning: option -{k} was given but never used (misspelt?)\n")
        out.flush()
    return left
