"""Checkpoints of the life simulation: one parallel HDF5 file per block (docs/hpc.md §3).

Layout: one dataset per :class:`FieldSpec`, of shape ``(n_items, *shape)``, indexed by work-item
id (never by rank), so a restart on any number of ranks is just another selection. The
attributes hold the caller's state (scene JSON, RNG states, cycles done, …) plus
``format_version``, ``code_version``, ``block``, ``ranks``, ``utc`` and, written last,
``complete = 1``.

Protocol of :func:`write_checkpoint` (collective): write ``ckpt_<block>.h5.tmp`` with the
``mpio`` driver, every metadata call with identical arguments on every rank and the same
number of collective data writes on every rank (ranks with less to write issue empty
``select_none`` writes through the low-level API: h5py's high-level slicing skips the HDF5
call for an empty selection, and the other ranks then wait forever in the collective write);
close, fsync on every rank, rename to ``ckpt_<block>.h5`` on rank 0, fsync the directory, point
``LATEST`` at it (temporary file + rename) and prune old files. A crash at any point leaves the
previous checkpoint and ``LATEST`` intact; a stale ``.tmp`` is never read and is overwritten.

:func:`find_latest` scans newest-first and skips files that cannot be opened, are incomplete,
or are torn; :func:`read_checkpoint` reads any rows and regions on any number of ranks.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from micropit_hpc import __version__
from micropit_hpc.errors import MicropitError, collective
from micropit_hpc.io.atomic import write_text_atomic
from micropit_hpc.io.hdf5 import h5py_module as _h5py
from micropit_hpc.io.outdir import fsync_path
from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.failure import abort_on_error
from micropit_hpc.parallel.share import from_root, raise_agreed

FORMAT_VERSION = 2
#: Datasets are chunked with a Fletcher-32 checksum per chunk from format 2 on.
CHECKSUMS_FROM_FORMAT = 2
#: Largest chunk, bytes (HDF5's limit is 4 GiB; smaller chunks bound the verifier's memory).
MAX_CHUNK_BYTES = 64 * 2**20
LATEST = "LATEST"
RESERVED_ATTRS = ("format_version", "code_version", "block", "ranks", "utc", "complete")
_NAME = re.compile(r"^ckpt_(\d+)\.h5$")
_TMP_NAME = re.compile(r"^ckpt_(\d+)\.h5\.tmp$")


class CheckpointError(MicropitError):
    """A checkpoint file that cannot be used: the message names the file and says why."""


@dataclass(frozen=True)
class FieldSpec:
    """A per-item array: on disk the dataset ``name`` of shape ``(n_items, *shape)``.

    ``name`` may contain ``/`` (HDF5 groups); ``dtype`` is a NumPy numeric type name.
    """

    name: str
    shape: tuple[int, ...]
    dtype: str

    def __post_init__(self):
        shape = tuple(int(n) for n in self.shape)
        if any(n < 0 for n in shape):
            raise MicropitError(f"checkpoint field {self.name!r}: negative shape {shape}")
        if not self.name or self.name.startswith("/") or self.name.endswith("/"):
            raise MicropitError(f"checkpoint field name {self.name!r}: must be non-empty and "
                                "must not start or end with '/'")
        if np.dtype(self.dtype).kind not in "biufc":
            raise MicropitError(f"checkpoint field {self.name!r}: dtype {self.dtype!r} is not "
                                "numeric")
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "dtype", np.dtype(self.dtype).str)


@dataclass(frozen=True, eq=False)
class Piece:
    """One rank's contribution: the elements ``[item, *region]`` of field ``name``.

    ``region`` is a tuple of slices over the per-item axes (missing trailing axes mean the
    whole axis; ``None`` is the whole per-item array); ``data`` has the region's shape.
    Pieces of different ranks must not overlap.
    """

    item: int
    name: str
    data: np.ndarray
    region: tuple[slice, ...] | None = field(default=None)


@dataclass(frozen=True)
class _Selection:
    """A hyperslab of a dataset: start, count and stride over ``(item, *per_item_axes)``."""

    start: tuple[int, ...]
    count: tuple[int, ...]
    stride: tuple[int, ...]

    @property
    def size(self) -> int:
        return int(np.prod(self.count))


def _parallel(comm, h5py) -> bool:
    """True to use the ``mpio`` driver on ``comm``; serial h5py for SerialComm or no MPI."""
    if isinstance(comm, SerialComm):
        return False
    if h5py.get_config().mpi:
        return True
    if comm.size > 1:
        raise MicropitError(
            f"h5py ({h5py.__file__}) has no MPI support, so {comm.size} ranks cannot write one "
            "checkpoint together: use Debian's python3-h5py-mpi with H5PY_ALWAYS_USE_MPI=1 "
            "(scripts/mpi-env.sh; docs/install.md, traps 1-2)")
    return False


def checkpoint_name(block: int) -> str:
    """The file name of block ``block``'s checkpoint."""
    return f"ckpt_{int(block):06d}.h5"


def block_of(path: str | Path) -> int | None:
    """The block number in a checkpoint's file name, or None for any other file."""
    m = _NAME.match(Path(path).name)
    return int(m.group(1)) if m else None


def _region_selection(spec: FieldSpec, item: int,
                      region: tuple[slice, ...] | None) -> _Selection:
    region = () if region is None else tuple(region)
    if len(region) > len(spec.shape):
        raise MicropitError(f"field {spec.name!r}: region {region} has more axes than the "
                            f"per-item shape {spec.shape}")
    start, count, stride = [int(item)], [1], [1]
    for axis, n in enumerate(spec.shape):
        s = region[axis] if axis < len(region) else slice(None)
        if not isinstance(s, slice):
            raise MicropitError(f"field {spec.name!r}: region entries must be slices, got {s!r}")
        lo, hi, step = s.indices(n)
        if step < 1:
            raise MicropitError(f"field {spec.name!r}: region step must be positive, got {s!r}")
        start.append(lo)
        count.append(len(range(lo, hi, step)))
        stride.append(step)
    return _Selection(tuple(start), tuple(count), tuple(stride))


def _check_piece(piece: Piece, specs: Mapping[str, FieldSpec], n_items: int) -> str | None:
    """Why ``piece`` cannot be written, or None."""
    spec = specs.get(piece.name)
    if spec is None:
        return f"piece for unknown field {piece.name!r} (fields: {', '.join(sorted(specs))})"
    if not 0 <= int(piece.item) < n_items:
        return f"field {piece.name!r}: item {piece.item} outside 0 … {n_items - 1}"
    try:
        sel = _region_selection(spec, piece.item, piece.region)
    except MicropitError as e:
        return str(e)
    data = np.asarray(piece.data)
    if data.shape != sel.count[1:]:
        return (f"field {piece.name!r}, item {piece.item}: data of shape {data.shape} for a "
                f"region of shape {sel.count[1:]}")
    if not np.can_cast(data.dtype, np.dtype(spec.dtype), "same_kind"):
        return (f"field {piece.name!r}, item {piece.item}: data of type {data.dtype} cannot be "
                f"stored as {np.dtype(spec.dtype)}")
    return None


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def encode_attr(key: str, value: Any):
    """An attribute value as stored: str, int, float and numeric arrays as they are; dicts,
    lists and tuples as JSON strings (exact for Python ints of any size, e.g. RNG states)."""
    if isinstance(value, bool | np.bool_):
        return np.bool_(value)
    if isinstance(value, int | np.integer):
        if not -2**63 <= int(value) < 2**63:
            raise MicropitError(f"checkpoint attribute {key!r}: integer {value} does not fit "
                                "in 64 bits; store it inside a dict (kept as JSON)")
        return np.int64(value)
    if isinstance(value, str | float | np.floating):
        return value
    if isinstance(value, np.ndarray) and value.dtype.kind in "biufc":
        return value
    if isinstance(value, dict | list | tuple):
        try:
            return json.dumps(value, sort_keys=True, default=_json_default)
        except (TypeError, ValueError) as e:
            raise MicropitError(f"checkpoint attribute {key!r}: cannot be stored as JSON "
                                f"({e})") from None
    raise MicropitError(f"checkpoint attribute {key!r}: unsupported type "
                        f"{type(value).__name__} (use str, int, float, a numeric array, or a "
                        "dict/list stored as JSON)")


def _decode_attr(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _checksummed(shape: tuple[int, ...], itemsize: int) -> dict:
    """Dataset options for a Fletcher-32 checksum per chunk (HDF5 verifies it on every read,
    so a flipped byte anywhere in the data makes the read fail): chunks of one item, split
    along the leading per-item axes until a chunk is at most :data:`MAX_CHUNK_BYTES`."""
    if not shape or 0 in shape:
        return {}   # nothing to store (HDF5 cannot chunk an empty dataset of fixed size)
    chunk = [1, *shape[1:]]
    for axis in range(1, len(chunk)):
        if int(np.prod(chunk)) * itemsize <= MAX_CHUNK_BYTES:
            break
        rest = int(np.prod(chunk[axis + 1:])) * itemsize
        chunk[axis] = max(1, min(chunk[axis], MAX_CHUNK_BYTES // max(rest, 1)))
    return {"chunks": tuple(chunk), "fletcher32": True}


def _at_stage(stage: str, path: Path) -> None:
    """Test hook, called at each step of :func:`write_checkpoint` (``"created"``, ``"data"``,
    ``"closed"``, ``"renamed"``); crash tests replace it with a function that kills the
    process. Does nothing in normal runs."""


def _write(dset, sel: _Selection | None, data, dxpl) -> None:
    """One (collective) write of ``data`` into ``sel``; ``sel`` None is an empty write."""
    h5s = _h5py().h5s
    fspace = dset.id.get_space()
    if sel is None or sel.size == 0:
        fspace.select_none()
        mspace = h5s.create_simple((1,))
        mspace.select_none()
        arr = np.zeros(1, dtype=dset.dtype)
    else:
        fspace.select_hyperslab(sel.start, sel.count, sel.stride)
        mspace = h5s.create_simple(sel.count)
        arr = np.ascontiguousarray(np.asarray(data, dtype=dset.dtype).reshape(sel.count))
    dset.id.write(mspace, fspace, arr, dxpl=dxpl)


def write_checkpoint(directory: str | Path, comm, block: int, n_items: int,
                     fields: Sequence[FieldSpec], pieces: Sequence[Piece],
                     attrs: Mapping[str, Any], keep: int = 3) -> Path:
    """Write block ``block``'s checkpoint into ``directory`` (collective over ``comm``).

    Every rank passes the same ``directory``, ``block``, ``n_items``, ``fields`` and ``keep``
    (checked, so that a mismatch is an error on every rank rather than a hang) and its
    own ``pieces`` (any number, including none). The attributes are rank 0's ``attrs``. Keeps
    the ``keep`` newest checkpoints up to this one (older ones and stale ``.tmp`` files of
    older blocks are deleted). Returns the final path on every rank.
    """
    h5py = _h5py()
    directory = Path(directory)
    specs = {s.name: s for s in fields}
    rank = comm.rank
    problem = None
    try:
        if len(specs) != len(fields):
            raise MicropitError("two checkpoint fields have the same name")
        if keep < 1:
            raise MicropitError(f"keep must be at least 1, got {keep}")
        if n_items < 0:
            raise MicropitError(f"n_items must not be negative, got {n_items}")
        problem = next((p for p in (_check_piece(pc, specs, n_items) for pc in pieces) if p),
                       None)
        if rank == 0 and problem is None:
            directory.mkdir(parents=True, exist_ok=True)
    except (MicropitError, OSError) as e:
        problem = str(e)
    # One collective carries the argument check, the piece counts and rank 0's attributes.
    signature = (str(directory), int(block), int(n_items),
                 tuple(sorted((s.name, s.shape, s.dtype) for s in fields)), int(keep))
    counts: dict[str, int] = {}
    for pc in pieces:
        counts[pc.name] = counts.get(pc.name, 0) + 1
    stored = None
    if rank == 0 and problem is None:
        try:
            stored = {k: encode_attr(k, v) for k, v in attrs.items()}
            clash = sorted(set(stored) & set(RESERVED_ATTRS))
            if clash:
                raise MicropitError(f"attributes {clash} are set by write_checkpoint itself")
            stored.update(format_version=np.int64(FORMAT_VERSION), code_version=__version__,
                          block=np.int64(block), ranks=np.int64(comm.size),
                          utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"))
        except MicropitError as e:
            problem = str(e)
    gathered = comm.allgather((problem, signature, counts, stored))
    bad = [(r, p) for r, (p, *_rest) in enumerate(gathered) if p]
    bad += [(r, f"arguments differ from rank 0's: {sig} != {gathered[0][1]}")
            for r, (_p, sig, *_rest) in enumerate(gathered) if sig != gathered[0][1]]
    if bad:
        text = "; ".join(f"rank {r}: {p}" for r, p in sorted(bad)[:4])
        raise collective(MicropitError(
            f"cannot write checkpoint block {block} in {directory}: {text}"))
    stored = gathered[0][3]
    n_writes = {name: max(g[2].get(name, 0) for g in gathered) for name in specs}

    final = directory / checkpoint_name(block)
    tmp = final.with_name(final.name + ".tmp")
    parallel = _parallel(comm, h5py)
    if parallel:
        f = h5py.File(tmp, "w", driver="mpio", comm=comm, libver="latest")
        dxpl = h5py.h5p.create(h5py.h5p.DATASET_XFER)
        dxpl.set_dxpl_mpio(h5py.h5fd.MPIO_COLLECTIVE)
    else:
        f = h5py.File(tmp, "w", libver="latest")
        dxpl = None
    with f, abort_on_error(comm, parallel):  # the close is collective: no unwinding alone
        _at_stage("created", tmp)
        for name in sorted(specs):  # metadata: identical calls in the same order everywhere
            spec = specs[name]
            shape = (n_items, *spec.shape)
            f.create_dataset(name, shape=shape, dtype=spec.dtype,
                             **_checksummed(shape, np.dtype(spec.dtype).itemsize))
        for name in sorted(specs):
            dset = f[name]
            mine = [pc for pc in pieces if pc.name == name]
            for i in range(n_writes[name]):  # the same number of collective writes everywhere
                if i < len(mine):
                    pc = mine[i]
                    _write(dset, _region_selection(specs[name], pc.item, pc.region), pc.data,
                           dxpl)
                else:
                    _write(dset, None, None, dxpl)
        _at_stage("data", tmp)
        for key in sorted(stored):
            f.attrs[key] = stored[key]
        f.attrs["complete"] = np.int64(1)  # last: a reader trusts nothing without it
    fsync_path(tmp)  # each rank flushes what its node wrote (matters on parallel FS)
    comm.Barrier()
    _at_stage("closed", tmp)

    problem = None
    if rank == 0:
        try:
            os.replace(tmp, final)
            fsync_path(directory)
            _at_stage("renamed", final)
            write_text_atomic(directory / LATEST, final.name + "\n")
            fsync_path(directory)
            _prune(directory, int(block), int(keep))
        except OSError as e:
            problem = f"{final}: {e}"
    raise_agreed(comm, None if problem is None else
                 f"checkpoint block {block} written but not published: {problem}",
                 CheckpointError)
    return final


def _prune(directory: Path, block: int, keep: int) -> None:
    """Delete checkpoints older than the ``keep - 1`` newest before ``block``, and the
    ``.tmp`` leftovers of older blocks. Files of later blocks are left alone."""
    older = sorted(((b, p) for p in directory.iterdir()
                    if (b := block_of(p)) is not None and b < block), reverse=True)
    for _b, p in older[keep - 1:]:
        p.unlink(missing_ok=True)
    for p in directory.iterdir():
        m = _TMP_NAME.match(p.name)
        if m and int(m.group(1)) < block:
            p.unlink(missing_ok=True)


@dataclass(frozen=True)
class Expected:
    """What a usable checkpoint must hold (the caller's layout): every field of ``fields``
    with its per-item shape (any shape for the names in ``any_shape``) and the same number of
    items in each (``n_items`` if given), every attribute of ``attrs``; every value of a
    float field finite, except the fields in ``nan_ok`` (checked by ``check`` if need be).
    ``check`` is called with the open file and its attributes and raises CheckpointError."""

    fields: Sequence[FieldSpec]
    n_items: int | None = None
    attrs: Sequence[str] = ()
    any_shape: Sequence[str] = ()
    nan_ok: Sequence[str] = ()
    check: Callable[[Any, dict[str, Any]], None] | None = None


def verify_checkpoint(path: str | Path, expect: Expected | None = None) -> dict[str, Any]:
    """The attributes of a usable checkpoint; CheckpointError if it cannot be opened, is not
    complete, was written by a newer format, is torn (a dataset's storage lies beyond the end
    of the file), or any element of any dataset cannot be read back (every element is read:
    from format 2 on each chunk carries a Fletcher-32 checksum, so a flipped byte fails the
    read; the file's metadata carries HDF5's own checksums). With ``expect``: also missing
    fields or attributes, wrong shapes and non-finite values. Serial reads, any rank."""
    h5py = _h5py()
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no such checkpoint file")
    try:
        size = path.stat().st_size
        with h5py.File(path, "r") as f:
            attrs = {k: _decode_attr(v) for k, v in f.attrs.items()}
            if attrs.get("complete") != 1:
                raise CheckpointError(f"{path}: incomplete checkpoint (no complete = 1 flag; "
                                      "the writer stopped before finishing it)")
            version = attrs.get("format_version")
            if not isinstance(version, int) or version > FORMAT_VERSION:
                raise CheckpointError(f"{path}: checkpoint format {version!r}, this "
                                      f"micropit_hpc reads format {FORMAT_VERSION} and older")
            datasets: list = []
            f.visititems(lambda _n, obj: datasets.append(obj)
                         if isinstance(obj, h5py.Dataset) else None)
            for d in datasets:
                offset = d.id.get_offset()
                if offset is not None and offset + d.id.get_storage_size() > size:
                    raise CheckpointError(f"{path}: torn checkpoint (dataset {d.name} ends "
                                          f"beyond the end of the file, {size} bytes)")
                if version >= CHECKSUMS_FROM_FORMAT and d.size and not d.fletcher32:
                    raise CheckpointError(f"{path}: dataset {d.name} has no checksum "
                                          f"(format {version} writes one for every dataset)")
            if expect is not None:
                _check_layout(path, f, attrs, expect)
            nan_ok = set() if expect is None else {n.strip("/") for n in expect.nan_ok}
            for d in datasets:
                finite = expect is not None and d.name.strip("/") not in nan_ok
                _read_all(path, d, finite)
            if expect is not None and expect.check is not None:
                expect.check(f, attrs)
    except CheckpointError:
        raise
    except Exception as e:  # any failure to read makes the file unusable
        raise CheckpointError(f"{path}: unreadable checkpoint ({type(e).__name__}: "
                              f"{' '.join(str(e).split())})") from e
    return attrs


def read_attrs(path: str | Path) -> dict[str, Any]:
    """The attributes of a checkpoint that :func:`find_latest` has verified already (no data
    is read). Serial, any rank."""
    try:
        with _h5py().File(path, "r") as f:
            return {k: _decode_attr(v) for k, v in f.attrs.items()}
    except Exception as e:  # the file changed since it was verified
        raise CheckpointError(f"{path}: unreadable checkpoint ({type(e).__name__}: {e})") from e


def _check_layout(path: Path, f, attrs: dict[str, Any], expect: Expected) -> None:
    missing = [a for a in expect.attrs if a not in attrs]
    if missing:
        raise CheckpointError(f"{path}: attribute {missing[0]!r} is missing")
    n_items = expect.n_items
    for spec in expect.fields:
        if spec.name not in f or not hasattr(f[spec.name], "shape"):
            raise CheckpointError(f"{path}: dataset {spec.name!r} is missing")
        d = f[spec.name]
        if n_items is None and d.ndim:
            n_items = d.shape[0]
        shape = (int(n_items), *spec.shape)
        if spec.name in expect.any_shape:
            shape = tuple(d.shape) if d.ndim == len(shape) and d.shape[0] == n_items else shape
        if tuple(d.shape) != shape:
            raise CheckpointError(f"{path}: dataset {spec.name!r} has shape {tuple(d.shape)}, "
                                  f"expected {shape}")
        if np.dtype(d.dtype) != np.dtype(spec.dtype):
            raise CheckpointError(f"{path}: dataset {spec.name!r} is {d.dtype}, expected "
                                  f"{np.dtype(spec.dtype)}")


def _read_all(path: Path, d, finite: bool) -> None:
    """Read every element of ``d`` (one item at a time: bounded memory); with ``finite``,
    refuse NaN and infinities in a float dataset."""
    if not d.size:
        return
    for i in range(d.shape[0]) if d.ndim else [()]:
        block = d[i]
        if finite and np.asarray(block).dtype.kind in "fc" and not np.all(np.isfinite(block)):
            bad = int(np.size(block) - np.count_nonzero(np.isfinite(block)))
            raise CheckpointError(f"{path}: dataset {d.name} holds {bad} non-finite values "
                                  f"(NaN or infinity) in item {i}")


def find_latest(directory: str | Path, comm=None,
                on_skip: Callable[[CheckpointError], None] | None = None,
                expect: Expected | None = None) -> Path | None:
    """The newest usable checkpoint in ``directory`` that ``LATEST`` leads to, or None.

    Candidates are the checkpoint ``LATEST`` names and the older ones, newest first; a
    checkpoint newer than ``LATEST``'s is a candidate only if it belongs to the same run
    (attribute ``run_id``; a crash between its rename and the update of ``LATEST``), so the
    leftovers of another run are never picked up. Without a ``LATEST`` file every checkpoint
    is a candidate. Skips ``*.tmp`` files and every file :func:`verify_checkpoint` rejects
    (with ``expect``; ``on_skip`` is told why), i.e. falls back to the previous good one.
    With ``comm``, rank 0 scans and broadcasts the answer (collective).
    """
    if comm is None or comm.size == 1:
        return _scan(Path(directory), on_skip, expect)

    def scan() -> str | None:
        try:
            found = _scan(Path(directory), on_skip, expect)
        except Exception as e:  # every rank must leave the broadcast
            raise CheckpointError(f"{directory}: scanning for checkpoints failed on rank 0: "
                                  f"{type(e).__name__}: {e}") from None
        return None if found is None else str(found)

    value = from_root(comm, scan, CheckpointError, world=True)
    return None if value is None else Path(value)


def _latest_pointer(directory: Path) -> int | None:
    """The block ``LATEST`` names, or None when there is no usable ``LATEST``."""
    try:
        name = (directory / LATEST).read_text().strip()
    except (OSError, UnicodeDecodeError):
        return None
    return block_of(name)


def _run_id(path: Path) -> str | None:
    try:
        with _h5py().File(path, "r") as f:
            value = f.attrs.get("run_id")
    except Exception:  # an unreadable file has no run to compare
        return None
    return None if value is None else str(_decode_attr(value))


def _scan(directory: Path, on_skip, expect: Expected | None = None) -> Path | None:
    if not directory.is_dir():
        return None
    candidates = sorted(((b, p) for p in directory.iterdir() if (b := block_of(p)) is not None),
                        reverse=True)
    pointer = _latest_pointer(directory)
    pointed = directory / checkpoint_name(pointer) if pointer is not None else None
    run = _run_id(pointed) if pointed is not None and pointed.is_file() else None
    for b, p in candidates:
        if pointer is not None and b > pointer and _run_id(p) != run:
            if on_skip is not None:
                on_skip(CheckpointError(f"{p}: newer than {directory / LATEST} "
                                        f"({checkpoint_name(pointer)}) and not of the same run "
                                        "(run_id differs): a leftover, not used"))
            continue
        try:
            verify_checkpoint(p, expect)
        except CheckpointError as e:
            if on_skip is not None:
                on_skip(e)
            continue
        return p
    return None


def read_checkpoint(path: str | Path, comm,
                    requests: Sequence[tuple[int, str, tuple[slice, ...] | None]],
                    ) -> tuple[dict[str, Any], dict[tuple[int, str], np.ndarray]]:
    """Read ``(attributes, {(item, name): array})`` for this rank's ``requests``.

    Each request is ``(item, field name, region)`` with ``region`` as in :class:`Piece`
    (None: the whole per-item array). Collective over ``comm`` (the file is opened with the
    ``mpio`` driver when it can be); the reads themselves are independent, so ranks may ask
    for different items, regions and numbers of requests, on any number of ranks. JSON
    attributes are returned as strings. Raises CheckpointError on every rank if any rank
    failed.
    """
    h5py = _h5py()
    path = Path(path)
    attrs: dict[str, Any] = {}
    out: dict[tuple[int, str], np.ndarray] = {}
    problem = None
    parallel = comm is not None and comm.size > 1 and _parallel(comm, h5py)
    try:
        if not path.is_file():
            raise CheckpointError(f"{path}: no such checkpoint file")
        f = (h5py.File(path, "r", driver="mpio", comm=comm) if parallel
             else h5py.File(path, "r"))
    except CheckpointError as e:
        problem, f = str(e), None
    except Exception as e:  # reported on every rank below
        problem, f = f"{path}: cannot be opened as HDF5 ({type(e).__name__}: {e})", None
    if f is not None:
        with f:
            try:
                attrs = {k: _decode_attr(v) for k, v in f.attrs.items()}
                if attrs.get("complete") != 1:
                    raise CheckpointError(f"{path}: incomplete checkpoint (no complete = 1 "
                                          "flag)")
                for item, name, region in requests:
                    if name not in f or not isinstance(f[name], h5py.Dataset):
                        raise CheckpointError(f"{path}: no field {name!r}")
                    d = f[name]
                    if not 0 <= int(item) < d.shape[0]:
                        raise CheckpointError(f"{path}: field {name!r} has items 0 … "
                                              f"{d.shape[0] - 1}, not {item}")
                    key = (int(item),) if region is None else (int(item), *region)
                    out[(int(item), name)] = np.asarray(d[key])
            except CheckpointError as e:
                problem = str(e)
            except Exception as e:  # reported on every rank below
                problem = f"{path}: read failed ({type(e).__name__}: {e})"
    if comm is not None and comm.size > 1:
        problems = [p for p in comm.allgather(problem) if p]
        problem = problems[0] if problems else None
    if problem:
        raise collective(CheckpointError(problem))
    return attrs, out
