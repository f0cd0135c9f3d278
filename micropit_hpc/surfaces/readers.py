"""Measured height maps from files → :class:`Topography` (docs/model.md §3).

Built-in formats (axis 0 of the stored matrix is x, the rolling direction; transpose a map that
was stored with the scan lines across rolling before writing it):

* ``.npy``: the heights alone; ``spacing=(dx, dy)`` [m] is required.
* ``.npz``: array ``heights`` (or the name given as ``dataset``), optional scalars ``dx``, ``dy``
  and ``unit`` (the unit of dx, dy; metres when absent).
* ``.txt``, ``.csv``, ``.dat``: a plain matrix (``numpy.loadtxt``, comma- or
  whitespace-separated, ``#`` comments); ``spacing=`` is required.
* ``.h5``, ``.hdf5``: the dataset named by ``dataset`` (default: the only 2-D dataset in the file);
  spacing from the attributes ``dx``, ``dy`` of the dataset (else of the file root), in metres
  unless an attribute ``unit`` gives their unit.

``height_unit`` gives the unit the heights are stored in. ``spacing=`` [m] overrides any spacing
in the file. Anything else goes through the optional SurfaceTopography package (ISO 25178-72
``.x3p``, ``.sdf``, ``.sur``, ``.opd``, ``.datx``, ``.plu``, …), which carries its own unit for
heights and sizes (``height_unit`` applies only when the file has none); ``dataset`` is then the
channel (index or name). The map is returned as read: detrend and periodise it afterwards.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

from micropit_hpc.surfaces.topography import Topography, TopographyError

__all__ = ["BUILTIN_EXTENSIONS", "HEIGHT_UNITS", "NAN_POLICIES", "read_topography"]

#: The largest peak-to-valley span [m] a height map may have: a roughness or form map spans
#: µm to mm; a span beyond 1 km is a corrupt file or a wrong unit (e.g. a map scaled by 1e300,
#: whose R_q would overflow), never a surface.
MAX_SPAN_M = 1e3
HEIGHT_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "μm": 1e-6, "nm": 1e-9}
NAN_POLICIES = ("error", "fill_mean", "interpolate")
_TEXT = (".txt", ".csv", ".dat")
_HDF5 = (".h5", ".hdf5")
BUILTIN_EXTENSIONS = (".npy", ".npz", *_TEXT, *_HDF5)
_READ_ERRORS = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile)


class _Raw(NamedTuple):
    heights: np.ndarray
    spacing: tuple | None  # [m], from the file
    key: str | None        # dataset / array / channel
    height_factor: float | None = None  # set when the file fixes the height unit


def _fail(path, problem: str, key: str | None = None) -> TopographyError:
    where = f"{path} [{key}]" if key else f"{path}"
    return TopographyError(f"{where}: {problem}")


def _first_line(err: Exception) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0] if text else ''}"


def _unit(path, what: str, unit, allowed=HEIGHT_UNITS) -> float:
    if isinstance(unit, bytes):
        unit = unit.decode()
    unit = str(np.asarray(unit).item()) if isinstance(unit, np.ndarray) else unit
    if unit not in allowed:
        raise _fail(path, f"{what} = {unit!r}: unknown unit (allowed: {', '.join(allowed)})")
    return allowed[unit]


def _spacing(path, what: str, values, key=None) -> tuple[float, float]:
    try:
        dx, dy = (float(np.asarray(v).item()) for v in values)
    except (TypeError, ValueError):
        raise _fail(path, f"{what} = {values!r}: must be two numbers (dx, dy) in metres",
                    key) from None
    for name, v in (("dx", dx), ("dy", dy)):
        if not (np.isfinite(v) and v > 0):
            raise _fail(path, f"{what} {name} = {v!r} m: must be positive and finite", key)
    return dx, dy


# ---- built-in formats ----------------------------------------------------------------------
def _magic(path: Path, magic: bytes, what: str) -> None:
    with open(path, "rb") as fh:
        if fh.read(len(magic)) != magic:
            raise ValueError(f"not {what} (its first bytes are not {magic!r})")


def _read_npy(path: Path, dataset) -> _Raw:
    _magic(path, b"\x93NUMPY", "a NumPy .npy file")
    return _Raw(np.load(path, allow_pickle=False), None, None)


def _read_npz(path: Path, dataset) -> _Raw:
    _magic(path, b"PK", "a NumPy .npz (zip) archive")
    key = dataset or "heights"
    with np.load(path, allow_pickle=False) as z:
        if key not in z.files:
            raise _fail(path, f"no array {key!r} (arrays in the file: "
                              f"{', '.join(z.files) or 'none'})")
        spacing = None
        if "dx" in z.files or "dy" in z.files:
            if not ("dx" in z.files and "dy" in z.files):
                raise _fail(path, "has only one of the arrays dx, dy: give both or neither")
            f = _unit(path, "array unit", z["unit"]) if "unit" in z.files else 1.0
            dx, dy = _spacing(path, "array", (z["dx"], z["dy"]))
            spacing = (dx * f, dy * f)
        return _Raw(z[key], spacing, key)


def _read_text(path: Path, dataset) -> _Raw:
    with open(path, encoding="utf-8", errors="replace") as fh:
        sample = fh.read(65536)
    return _Raw(np.loadtxt(path, delimiter="," if "," in sample else None, ndmin=2), None, None)


def _read_hdf5(path: Path, dataset) -> _Raw:
    import h5py

    with h5py.File(path, "r") as f:
        names: list[str] = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        if dataset is None:
            two_d = [n for n in names if f[n].ndim == 2]
            if len(two_d) != 1:
                found = ", ".join(f"{n} {f[n].shape}" for n in names) or "none"
                raise _fail(path, f"{len(two_d)} 2-D datasets, pass dataset= to choose "
                                  f"(datasets in the file: {found})")
            dataset = two_d[0]
        dataset = str(dataset).strip("/")
        if dataset not in names:
            raise _fail(path, f"dataset {dataset!r} not found (datasets in the file: "
                              f"{', '.join(names) or 'none'})")
        ds = f[dataset]
        attrs = ds.attrs if ("dx" in ds.attrs or "dy" in ds.attrs) else f.attrs
        spacing = None
        if "dx" in attrs or "dy" in attrs:
            if not ("dx" in attrs and "dy" in attrs):
                raise _fail(path, "has only one of the attributes dx, dy", dataset)
            fac = _unit(path, "attribute unit", attrs["unit"]) if "unit" in attrs else 1.0
            dx, dy = _spacing(path, "attribute", (attrs["dx"], attrs["dy"]), dataset)
            spacing = (dx * fac, dy * fac)
        return _Raw(ds[()], spacing, dataset)


_READERS = {".npy": _read_npy, ".npz": _read_npz, **dict.fromkeys(_TEXT, _read_text),
            **dict.fromkeys(_HDF5, _read_hdf5)}


# ---- SurfaceTopography adapter ---------------------------------------------------------------
_ST_UNITS = {**HEIGHT_UNITS, "pm": 1e-12, "Å": 1e-10, "km": 1e3}


_ST_NAMES = {"m": "m", "mm": "mm", "um": "µm", "µm": "µm", "μm": "µm", "nm": "nm"}


def _read_surface_topography(path: Path, dataset, height_unit: str,
                             spacing: tuple[float, float] | None = None) -> _Raw:
    """Read an instrument format through SurfaceTopography. Its physical sizes and units are
    used where the file stores them; where it stores no sizes, ``spacing`` [m] gives them (the
    package refuses such a file without sizes)."""
    try:
        import SurfaceTopography as st
    except ImportError:
        raise _fail(path, f"unknown extension {path.suffix!r}: the built-in formats are "
                          f"{', '.join(BUILTIN_EXTENSIONS)}; the optional SurfaceTopography "
                          "package adds .x3p, .sdf, .sur, .opd, .datx, .plu and other "
                          "instrument formats: install it as docs/install.md says "
                          "(`bash scripts/install-surfaces.sh`; a plain `pip install` would "
                          "replace NumPy)") from None
    key = None if dataset is None else str(dataset)
    try:
        with st.open_topography(str(path)) as reader:
            index = 0 if dataset is None else _channel_index(path, reader, dataset)
            ch = reader.channels[index]
            nb, unit = tuple(ch.nb_grid_pts), ch.unit
            kwargs = {"channel_index": index}
            if ch.physical_sizes is None and spacing is not None and len(nb) == 2:
                st_unit = unit or _ST_NAMES[height_unit]
                f = _ST_UNITS[st_unit]
                kwargs["physical_sizes"] = (nb[0] * spacing[0] / f, nb[1] * spacing[1] / f)
                if unit is None:
                    kwargs["unit"] = st_unit
            elif ch.physical_sizes is None and len(nb) == 2:
                raise _fail(path, "the file stores no physical size: give "
                                  "surface.spacing_um = [dx, dy]", key)
            t = reader.topography(**kwargs)
            nb, sizes = tuple(t.nb_grid_pts), t.physical_sizes
            heights = np.ma.filled(np.ma.asarray(t.heights(), dtype=float), np.nan)
    except TopographyError:
        raise
    except Exception as err:  # any failure inside the third-party reader
        raise _fail(path, f"SurfaceTopography cannot read it ({_first_line(err)})", key) from None
    if len(nb) != 2:
        raise _fail(path, f"a line scan of {nb} points, not a 2-D map", key)
    factor = (_unit(path, "SurfaceTopography unit", t.unit, _ST_UNITS) if t.unit is not None
              else HEIGHT_UNITS[height_unit])
    own = None
    if sizes is not None and "physical_sizes" not in kwargs:
        own = _spacing(path, "SurfaceTopography spacing",
                       (sizes[0] * factor / nb[0], sizes[1] * factor / nb[1]), key)
    return _Raw(heights, own, key, factor)


def _channel_index(path: Path, reader, dataset) -> int:
    names = [c.name for c in reader.channels]
    if isinstance(dataset, int) or str(dataset).isdigit():
        if not 0 <= int(dataset) < len(names):
            raise _fail(path, f"channel {dataset} not found (channels 0 to {len(names) - 1}: "
                              f"{', '.join(names)})")
        return int(dataset)
    if dataset not in names:
        raise _fail(path, f"channel {dataset!r} not found (channels: {', '.join(names)})")
    return names.index(dataset)


# ---- NaN handling --------------------------------------------------------------------------
def _fill_by_interpolation(h: np.ndarray, bad: np.ndarray, dx: float, dy: float) -> None:
    """Fill ``h[bad]`` in place: linear interpolation (Delaunay, scipy griddata) from the valid
    points that border the holes, nearest valid point where that leaves a gap (outside their
    convex hull, e.g. a missing edge). Coordinates are physical, so Δx ≠ Δy is respected."""
    from scipy import ndimage
    from scipy.interpolate import griddata

    ring = ndimage.binary_dilation(bad, structure=np.ones((3, 3), bool)) & ~bad
    scale = np.array([dx, dy])
    src, targets = np.argwhere(ring) * scale, np.argwhere(bad) * scale
    values = h[ring]
    try:
        filled = griddata(src, values, targets, method="linear")
    except (RuntimeError, ValueError):  # QhullError (a RuntimeError): points on one line
        filled = np.full(len(targets), np.nan)
    gap = np.isnan(filled)
    if gap.any():  # the nearest valid point to any hole point lies on the ring
        filled[gap] = griddata(src, values, targets[gap], method="nearest")
    h[bad] = filled


def _apply_nan_policy(path, key, h: np.ndarray, policy: str, dx: float, dy: float) -> str:
    bad = ~np.isfinite(h)
    n = int(np.count_nonzero(bad))
    if n == 0:
        return ""
    frac = f"{n} of {h.size} points ({100 * n / h.size:.3g}%)"
    if n == h.size:
        raise _fail(path, f"all {h.size} points are NaN or inf: nothing to read", key)
    if policy == "error":
        raise _fail(path, f"{frac} are NaN or inf; set nan_policy='fill_mean' or "
                          "'interpolate' to fill them", key)
    if policy == "fill_mean":
        h[bad] = h[~bad].mean()
    else:
        _fill_by_interpolation(h, bad, dx, dy)
    return f"; {frac} non-finite, filled ({policy})"


# ---- entry point ---------------------------------------------------------------------------
def read_topography(path, *, dataset=None, spacing=None, height_unit: str = "m",
                    nan_policy: str = "error") -> Topography:
    """Read a height map (formats in the module docstring) as a :class:`Topography` [m].

    ``spacing=(dx, dy)`` [m] is needed where the file has none and overrides the file's.
    ``height_unit`` ("m", "mm", "um", "nm") is the unit of the stored heights.
    ``nan_policy``: "error" (default) refuses a map with NaN or inf points; "fill_mean" puts the
    mean of the valid points there; "interpolate" fills them from valid neighbours (linear, then
    nearest). A map with no valid point is always an error. Every problem raises
    :class:`TopographyError` with one line naming the file, the dataset, the value and the rule.
    """
    path = Path(path)
    if nan_policy not in NAN_POLICIES:
        raise _fail(path, f"nan_policy = {nan_policy!r}: unknown "
                          f"(allowed: {', '.join(NAN_POLICIES)})")
    h_factor = _unit(path, "height_unit", height_unit)
    if spacing is not None:
        spacing = _spacing(path, "spacing", tuple(spacing) if np.ndim(spacing) else (spacing,))
    if not path.is_file():
        raise _fail(path, "file not found" if not path.exists() else "not a regular file")
    ext = path.suffix.lower()
    if ext in _READERS:
        try:
            raw = _READERS[ext](path, dataset)
        except TopographyError:
            raise
        except _READ_ERRORS as err:
            raise _fail(path, f"cannot read it as {ext} ({_first_line(err)})", dataset) from None
    else:
        raw = _read_surface_topography(path, dataset, height_unit, spacing)
    key = raw.key
    dtype = np.asarray(raw.heights).dtype
    if dtype.kind == "c":
        raise _fail(path, f"heights of dtype {dtype}: complex numbers, not heights (a height "
                          "map is real: store its real part, or the map before a Fourier "
                          "transform)", key)
    if dtype.kind == "b":
        raise _fail(path, f"heights of dtype {dtype}: true/false values, a mask rather than "
                          "a height map", key)
    try:
        h = np.array(raw.heights, dtype=np.float64)
    except (TypeError, ValueError):
        raise _fail(path, f"heights of dtype {dtype}: not numeric", key) from None
    if h.ndim != 2:
        raise _fail(path, f"heights of shape {h.shape}: must be a 2-D map", key)
    if h.shape[0] < 2 or h.shape[1] < 2:
        which = "a single row" if h.shape[0] < 2 else "a single column"
        raise _fail(path, f"heights of shape {h.shape} are {which}: need at least 2 points "
                          "along x (axis 0) and y (axis 1)", key)
    if spacing is None:
        source = "file"
    elif raw.spacing is None:
        source = "argument (the file stores none)"
    else:
        source = (f"argument, overriding the file's own {raw.spacing[0]:.6g} m x "
                  f"{raw.spacing[1]:.6g} m")
    spacing = spacing or raw.spacing
    if spacing is None:
        raise _fail(path, f"the {ext} file gives no grid spacing: pass spacing=(dx, dy) in "
                          "metres", key)
    filled = _apply_nan_policy(path, key, h, nan_policy, *spacing)
    factor = raw.height_factor if raw.height_factor is not None else h_factor
    h *= factor
    unit = "file unit" if raw.height_factor is not None else height_unit
    finite = h[np.isfinite(h)]
    span = float(finite.max()) - float(finite.min())   # Python floats: inf, no warning
    if not np.isfinite(span) or span > MAX_SPAN_M:
        raise _fail(path, f"heights span {span:.3g} m (in {unit}): no measured roughness map "
                          f"spans more than {MAX_SPAN_M / 1e3:g} km; check height_unit (or "
                          "the file's own unit)", key)
    if span == 0.0:
        raise _fail(path, f"all {h.size} heights are {finite[0]:.6g} m: a constant map has no "
                          "roughness (for a smooth body use surface.kind = \"smooth\")", key)
    prov = (f"read {path}" + (f" [{key}]" if key else "") + f"; heights in {unit}; "
            f"spacing {spacing[0]:.6g} m x {spacing[1]:.6g} m from {source}{filled}")
    return Topography(h, spacing[0], spacing[1], prov)
