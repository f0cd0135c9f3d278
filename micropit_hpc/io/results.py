"""Results of ``micropit run`` (docs/outputs.md): ``summary.csv`` and ``results.h5``.

Both are written by world rank 0 as ``*.tmp``, flushed, fsynced and renamed, so a crash never
leaves a half-written file under the final name. Engineering units in the CSV (µm, GPa, %); SI
in the HDF5 file, with the unit of every dataset in its ``unit`` attribute ("1" for a pure
number), the window's coordinates in ``grid/x``, ``grid/y``, ``grid/z``, and an XDMF file
(``results.xdmf``, :func:`write_xdmf`) beside it so that ParaView and VisIt open the maps.
Provenance: the code's commit, the library versions and the SHA-256 of the input files
(:mod:`micropit_hpc.io.provenance`).

:func:`load_results` reads a run back (results.h5, and summary.csv beside it) into small frozen
dataclasses (:class:`Results`), so that postprocessing scripts need neither h5py nor the
dataset paths; a file that is not such a results file is a :class:`ResultsError`.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from micropit_hpc import __version__, source_commit
from micropit_hpc.errors import MicropitError
from micropit_hpc.io.atomic import write_text_atomic
from micropit_hpc.io.hdf5 import atomic_h5, h5py_module, scene_json
from micropit_hpc.regime import block_flags
from micropit_hpc.state import BODY_FIELDS, RECORD_UNITS

__all__ = ["MAP_UNITS", "Grid", "MethodB", "Results", "ResultsError", "ResultsHandler", "Table",
           "load_results", "load_summary", "write_results", "write_summary", "write_xdmf"]

#: Unit of each final map (``maps/item_NNNNN/bodyB/<name>``): the stored state of a body
#: (:data:`~micropit_hpc.state.BODY_FIELDS`) and the damage's worst layer per column.
MAP_UNITS = {**{f.name: f.unit for f in BODY_FIELDS}, "damage_risk": "1"}
#: Unit of each item column (``items/<name>``).
ITEM_UNITS = {"id": "1", "position": "1", "k_lub": "s", "roughness_scale": "1", "patch": "1",
              "S": "1", "p0": "Pa", "Lambda": "1", "lambda_GF": "1", "hc": "m",
              "single_pair": "1", "roll_angle": "rad", "radial_position": "m",
              "S_lambda": "1"}


def _cell(v) -> str:
    if isinstance(v, float):
        return format(v, ".6g")
    return str(v)


def write_summary(path: str | Path, columns: Sequence[str], rows: Sequence[tuple]) -> Path:
    """summary.csv: one row per item, body and block end."""
    text = ",".join(columns) + "\n" + "".join(",".join(_cell(v) for v in r) + "\n"
                                              for r in rows)
    path = Path(path)
    try:
        write_text_atomic(path, text)
    except OSError as e:
        raise MicropitError(f"cannot write {path}: {e.strerror or e}") from None
    return path


def write_results(path: str | Path, study, records: Mapping[int, list],
                  maps: Mapping[int, Mapping[str, np.ndarray]], meta: Mapping[str, object]) -> Path:
    """results.h5: the items, their block histories and their final maps (docs/outputs.md),
    and results.xdmf beside it (:func:`write_xdmf`)."""
    import json

    from micropit_hpc.io.provenance import input_hashes, library_versions

    path = Path(path)
    try:
        with atomic_h5(path) as f:
            f.attrs["code_version"] = __version__
            f.attrs["source_commit"] = source_commit()
            f.attrs["library_versions"] = json.dumps(library_versions(), sort_keys=True)
            f.attrs["input_sha256"] = json.dumps(input_hashes(study.scene), sort_keys=True)
            if study.scene.lubricant.derived:
                f.attrs["lubricant_derived"] = study.scene.lubricant.derived
            f.attrs["scene"] = scene_json(study.scene.document)
            # the length the run used, the integration's default resolved (a later default
            # would read the same document differently)
            f.attrs["process_length_m"] = float(study.scene.fatigue.process_length)
            f.attrs["scene_file"] = str(study.scene.source)
            f.attrs["created_utc"] = _dt.datetime.now(_dt.UTC).isoformat()
            for k, v in meta.items():
                f.attrs[k] = v
            items = study.items
            tab = f.create_group("items")
            tab["id"] = np.array([i.id for i in items])
            tab["position"] = np.array([i.position for i in items])
            tab["k_lub"] = np.array([i.k_lub for i in items])
            tab["roughness_scale"] = np.array([i.scale for i in items])
            tab["patch"] = np.array([i.patch for i in items])
            conds = [study.base.conditions[i.position - 1] for i in items]
            tab["S"] = np.array([c.S for c in conds])
            tab["p0"] = np.array([c.p0 for c in conds])
            tab["Lambda"] = np.array([study.item_lambda(i) for i in items])
            tab["lambda_GF"] = np.array([study.item_lambda_gf(i) for i in items])
            mb = study.method_b
            tab["S_lambda"] = tab["lambda_GF"][()] / mb.lambda_gfp
            tab["hc"] = np.array([c.hc for c in conds])
            tab["single_pair"] = np.array([c.region == "single" for c in conds], dtype=np.uint8)
            tab["roll_angle"] = np.array([c.roll_angle for c in conds])   # NaN for a disc rig
            tab["radial_position"] = np.array([c.radial_position for c in conds])
            f.attrs["window_problems"] = "; ".join(study.window_problems) or "none"
            for name, unit in ITEM_UNITS.items():
                tab[name].attrs["unit"] = unit
            iso = f.create_group("iso6336_22")      # Method B along the path (iso6336_22.py)
            iso["roll_angle"] = mb.roll_angle
            iso["roll_angle"].attrs["unit"] = "rad"
            iso["lambda_GF"] = mb.lambda_gf
            iso["lambda_GF"].attrs["unit"] = "1"
            for k, v in (("lambda_GF_min", mb.lambda_gf_min), ("roll_angle_min",
                         mb.roll_angle_min), ("Ra", mb.ra), ("lambda_GFT", mb.lambda_gft),
                         ("W_W", mb.ww), ("lambda_GFP", mb.lambda_gfp),
                         ("S_lambda", mb.s_lambda)):
                iso.attrs[k] = v
            iso.attrs["summary"] = "\n".join(mb.lines())
            mesh = study.base.mesh
            if mesh is not None:   # the path points A–E, for plots [rad, roll angle of gear 1]
                pts = f.create_group("path")
                for label in "ABCDE":
                    pts.attrs[f"{label}_roll_angle"] = float(mesh.roll_angle(getattr(mesh,
                                                                                    label)))
            hist = f.create_group("history")
            for iid, recs in records.items():
                g = hist.create_group(f"item_{iid:05d}")
                for name, unit in RECORD_UNITS.items():
                    g[name] = np.array([getattr(r, name) for r in recs])  # (blocks[, 2 bodies])
                    g[name].attrs["unit"] = unit
                flags = [";".join(block_flags(r, study.z_max, not study.window_problems,
                                              study.scene.life.wear_tol))
                         or "none" for r in recs]
                g.create_dataset("flags", data=np.array(flags, dtype=object),
                                 dtype=h5py_module().string_dtype())
                g["flags"].attrs["unit"] = "1"
                g["flags"].attrs["description"] = ("per block: flags outside the model's range "
                                                   "(docs/life.md, \"The model's range\")")
            mg = f.create_group("maps")
            for iid, m in maps.items():
                g = mg.create_group(f"item_{iid:05d}")
                for name, arr in m.items():
                    d = g.create_dataset(name, data=arr, compression="gzip",
                                         compression_opts=4, shuffle=True)
                    d.attrs["unit"] = MAP_UNITS[name.split("/")[-1]]
            grid, z = study.plan.window.grid, study.plan.window.z
            for name, value, doc in (
                    ("x", grid.x, "along rolling, first index of every map"),
                    ("y", grid.y, "across rolling, second index of every map"),
                    ("z", z, "depth below the surface of the damage layers, first index of "
                             "the damage"),
                    ("dx", grid.dx, "spacing along rolling"),
                    ("dy", grid.dy, "spacing across rolling")):
                f[f"grid/{name}"] = value
                f[f"grid/{name}"].attrs["unit"] = "m"
                f[f"grid/{name}"].attrs["meaning"] = doc
            f.attrs["complete"] = 1
        write_xdmf(path.with_suffix(".xdmf"), path, grid.nx, grid.ny, len(z),
                   {iid: sorted(m) for iid, m in maps.items()})
    except OSError as e:
        raise MicropitError(f"cannot write {path}: {e.strerror or e}") from None
    return path


class ResultsHandler:
    """Writes a run's results when its loop ends (a :class:`~micropit_hpc.runner.Handler`):
    the final maps gathered from every group (collective), then on world rank 0 summary.csv
    and results.h5 (+ results.xdmf) staged and published into ``out`` with its manifest
    (:mod:`micropit_hpc.io.outdir`), complete or, after a stop, partial. ``meta``: attributes
    of results.h5 besides the run's status; ``t0``: the run's start (``time.perf_counter``)
    for its wall time; ``log`` prints on rank 0."""

    def __init__(self, out: str | Path, meta: Mapping[str, object], t0: float, log):
        self.out, self.meta, self.t0, self.log = Path(out), dict(meta), t0, log

    def start(self, study, blocks: int, start: int) -> None:
        pass

    def progress(self, *args) -> None:
        pass

    def block(self, k: int, blocks: int, records) -> None:
        pass

    def finish(self, outcome) -> None:
        import time

        from micropit_hpc.io import outdir
        from micropit_hpc.parallel.petsc import stage

        study, out = outcome.study, self.out
        with stage("results"):
            maps = study.gather_maps()
            if study.comm.rank != 0:
                return
            meta = {**self.meta, "wall_s": time.perf_counter() - self.t0,
                    "status": outcome.status, "blocks_done": outcome.blocks_done,
                    "restarted_from_block": outcome.start_block}
            staged = outdir.staging(out)
            write_summary(staged / "summary.csv", study.summary_columns,
                          study.summary(outcome.records))
            write_results(staged / "results.h5", study, outcome.records, maps, meta)
            try:
                manifest = outdir.publish(out, ("summary.csv", "results.h5", "results.xdmf"), {
                    "status": outcome.status, "blocks_done": outcome.blocks_done,
                    "blocks": study.blocks, "run_id": outcome.run_id})
            except OSError as e:
                raise MicropitError(f"cannot publish the results in {out}: "
                                    f"{e.strerror or e}") from None
            what = ("results" if outcome.status == "done"
                    else f"partial results (block {outcome.blocks_done} of {study.blocks})")
            self.log(f"wrote {what}: {out / 'summary.csv'} and {out / 'results.h5'} "
                     f"({manifest}) in {time.perf_counter() - self.t0:.1f} s")


_STATE_FIELDS = {f.name: f for f in BODY_FIELDS}


def _layered(name: str) -> bool:
    """Whether the map ``bodyB/<field>`` is a layered state field (N_z, n_x, n_y)."""
    f = _STATE_FIELDS.get(name.split("/")[-1])
    return f is not None and f.layered


def _map_dtype(name: str) -> str:
    """The stored dtype of the map ``bodyB/<field>`` ("f8" for derived maps)."""
    f = _STATE_FIELDS.get(name.split("/")[-1])
    return "f8" if f is None else f.dtype


def write_xdmf(xdmf: Path, h5: Path, nx: int, ny: int, nz: int,
               maps: Mapping[int, Sequence[str]]) -> Path:
    """An XDMF 3 file describing the final maps of ``h5`` (relative reference, so the two
    files move together): per item a 2-D rectilinear grid with the surface maps (x, y) and a
    3-D one with the damage (z, x, y). XDMF orders a rectilinear mesh's dimensions slowest
    first and names the fastest axis X, so the file's X axis is our y (across rolling), its Y
    axis our x (along rolling) and its Z axis the depth z: ParaView shows the rolling
    direction vertically and depth along +Z."""
    ref = h5.name

    def item(dims: str, dtype: str, where: str) -> str:
        kind, prec = {"f8": ("Float", 8), "u1": ("UChar", 1)}[dtype]
        return (f'<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{prec}" '
                f'Format="HDF">{ref}:{where}</DataItem>')

    out = ['<?xml version="1.0" ?>', '<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>',
           '<Xdmf Version="3.0">', '  <Domain>']
    for iid, names in maps.items():
        base = f"/maps/item_{iid:05d}"
        surf = [n for n in names if not _layered(n)]
        vol = [n for n in names if _layered(n)]
        out += [f'    <Grid Name="item_{iid:05d}_surface" GridType="Uniform">',
                f'      <Topology TopologyType="2DRectMesh" Dimensions="{nx} {ny}"/>',
                '      <Geometry GeometryType="VXVY">',
                "        " + item(str(ny), "f8", "/grid/y"),
                "        " + item(str(nx), "f8", "/grid/x"),
                "      </Geometry>"]
        for n in surf:
            dtype, unit = _map_dtype(n), MAP_UNITS[n.split("/")[-1]]
            out += [f'      <Attribute Name="{n.replace("/", "_")} [{unit}]" '
                    'AttributeType="Scalar" Center="Node">',
                    "        " + item(f"{nx} {ny}", dtype, f"{base}/{n}"),
                    "      </Attribute>"]
        out.append("    </Grid>")
        if vol:
            out += [f'    <Grid Name="item_{iid:05d}_damage" GridType="Uniform">',
                    f'      <Topology TopologyType="3DRectMesh" Dimensions="{nz} {nx} {ny}"/>',
                    '      <Geometry GeometryType="VXVYVZ">',
                    "        " + item(str(ny), "f8", "/grid/y"),
                    "        " + item(str(nx), "f8", "/grid/x"),
                    "        " + item(str(nz), "f8", "/grid/z"),
                    "      </Geometry>"]
            for n in vol:
                out += [f'      <Attribute Name="{n.replace("/", "_")} '
                        f'[{MAP_UNITS[n.split("/")[-1]]}]" AttributeType="Scalar" Center="Node">',
                        "        " + item(f"{nz} {nx} {ny}", _map_dtype(n), f"{base}/{n}"),
                        "      </Attribute>"]
            out.append("    </Grid>")
    out += ["  </Domain>", "</Xdmf>", ""]
    write_text_atomic(xdmf, "\n".join(out))
    return xdmf


# ---- reading a run back ------------------------------------------------------------------------

#: The columns of summary.csv in order, each with its unit (engineering units, docs/outputs.md;
#: "" for text): the one declaration of the table (``study.SUMMARY_COLUMNS`` is its keys).
SUMMARY_UNITS = {"item": "1", "position": "1", "S": "1", "p0_GPa": "GPa", "Lambda": "1",
                 "k_lub_s": "s", "body": "1", "cycles": "1", "Ap_pct": "%", "max_damage": "1",
                 "wear_um": "µm", "Rq_um": "µm", "lambda_GF": "1", "S_lambda": "1",
                 "slope_dq": "rad", "low_cycle_damage_pct": "%", "low_cycle_pits_pct": "%",
                 "p_lim_area_pct": "%", "deep_damage_ratio": "1", "pit_depth_max_um": "µm",
                 "phi": "1", "pit_load_pct": "%", "sub_blocks": "1", "wear_cycles": "1",
                 "flags": ""}
#: What a results.h5 must hold for :func:`load_results` (older files may lack the rest).
_REQUIRED_GRID = ("x", "y", "z", "dx", "dy")
_REQUIRED_HISTORY = ("cycles", "Ap")


class ResultsError(MicropitError):
    """A run's results (results.h5, summary.csv) that cannot be read: the message names the file
    and what is missing or wrong."""


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class Table(Mapping):
    """Named arrays with their units: the columns of a table (one value per row: per item, per
    block, per summary.csv row) or the maps of one body. Read-only; ``table["Ap"]``,
    ``"lambda_GF" in table``, ``table.units["Ap"]``."""

    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    #: where the arrays come from, for messages (``FILE:GROUP``)
    source: str = ""

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise KeyError(f"{self.source}: no {name!r} (it has "
                           f"{', '.join(self.columns) or 'nothing'})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        return len(self.columns)

    @property
    def rows(self) -> int:
        """Length of the first axis (items, blocks or summary rows; 0 when empty)."""
        return next((len(a) for a in self.columns.values() if a.ndim), 0)

    def __repr__(self) -> str:
        return f"Table({self.source}: {self.rows} rows; {', '.join(self.columns)})"


@dataclass(frozen=True, eq=False)
class Grid:
    """The window (``grid/``) [m]: ``x`` along rolling (the first index of every map), ``y``
    across it (the second), ``z`` the depths of the damage layers (the first index of
    ``damage``), the spacings ``dx``, ``dy``."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    dx: float
    dy: float
    unit: str = "m"

    @property
    def shape(self) -> tuple[int, int]:
        """(n_x, n_y) of every surface map."""
        return (len(self.x), len(self.y))


@dataclass(frozen=True, eq=False)
class MethodB:
    """ISO/TS 6336-22 Method B along the path (``iso6336_22/``): ``roll_angle`` [rad] and
    ``lambda_GF`` at each point, its minimum and where, the flank R_a [m], λ_GFT, W_W, λ_GFP
    and S_λ (NaN without the oil's rating) and the lines ``micropit contact`` prints."""

    roll_angle: np.ndarray
    lambda_GF: np.ndarray
    lambda_GF_min: float = math.nan
    roll_angle_min: float = math.nan
    Ra: float = math.nan
    lambda_GFT: float = math.nan
    W_W: float = math.nan
    lambda_GFP: float = math.nan
    S_lambda: float = math.nan
    summary: str = ""


@dataclass(frozen=True, eq=False)
class Results:
    """One ``micropit run`` as written in results.h5 (docs/outputs.md), SI units.

    ``attrs``: the root attributes (str, int, float); the common ones also as properties.
    ``items``: one row per work item (``items/``: ``id``, ``position``, ``S``, ``p0``, ...).
    ``history``: item id → its per-block table (``history/item_NNNNN/``: ``cycles``, ``Ap``
    (blocks × 2 bodies), ..., ``flags`` as strings). ``grid``: the window's coordinates.
    ``iso6336_22``: Method B along the path (None in files without it). ``path_points``: roll
    angle [rad] of the points A–E of a gear's path of contact (empty for a disc rig).
    ``map_names``: item id → the names of its final maps (``body1/heights``, ...), read by
    :meth:`maps`. ``summary``: summary.csv beside the file (None when it is not there).
    """

    file: Path
    attrs: Mapping[str, object]
    items: Table
    history: Mapping[int, Table]
    grid: Grid
    iso6336_22: MethodB | None = None
    path_points: Mapping[str, float] = field(default_factory=dict)
    map_names: Mapping[int, tuple[str, ...]] = field(default_factory=dict)
    summary: Table | None = None

    def __repr__(self) -> str:
        blocks = max((h.rows for h in self.history.values()), default=0)
        return (f"Results({self.file}: {self.items.rows} items, {blocks} blocks, status "
                f"{self.status or '?'})")

    @property
    def folder(self) -> Path:
        return self.file.parent

    @property
    def ids(self) -> list[int]:
        """The work-item ids, in the file's order."""
        return [int(i) for i in self.items["id"]]

    @property
    def status(self) -> str:
        """``done``, or ``stopped`` for the partial results of a run that stopped early."""
        return str(self.attrs.get("status", ""))

    @property
    def scene(self) -> dict:
        """The scene file as read (the ``scene`` attribute, parsed from JSON)."""
        return json.loads(str(self.attrs.get("scene", "{}")))

    @property
    def scene_file(self) -> str:
        return str(self.attrs.get("scene_file", ""))

    @property
    def source_commit(self) -> str:
        return str(self.attrs.get("source_commit", ""))

    @property
    def library_versions(self) -> dict:
        return json.loads(str(self.attrs.get("library_versions", "{}")))

    @property
    def input_sha256(self) -> dict:
        return json.loads(str(self.attrs.get("input_sha256", "{}")))

    @property
    def window_problems(self) -> tuple[str, ...]:
        """Why the window does not hold the synthetic surfaces; empty when it does."""
        text = str(self.attrs.get("window_problems", "none"))
        return () if text == "none" else tuple(text.split("; "))

    def maps(self, item: int, body: int, *names: str) -> Table:
        """The final maps of ``body`` (1 or 2) of work item ``item`` (``heights``, ``damage``,
        ``damage_risk``, ``pitted``, ``wear``, ``pit_depth``; ``names`` to read only some),
        read from the file now: (n_x, n_y), ``damage`` (N_z, n_x, n_y)."""
        have = [n.split("/", 1)[1] for n in self.map_names.get(int(item), ())
                if n.startswith(f"body{body}/")]
        where = f"maps/item_{int(item):05d}/body{body}"
        if not have:
            raise ResultsError(f"{self.file}: no maps of item {item}, body {body} ({where})")
        missing = [n for n in names if n not in have]
        if missing:
            raise ResultsError(f"{self.file}: {where} has no {', '.join(missing)} (it has "
                               f"{', '.join(have)})")
        with _open(self.file) as f:
            cols, units = {}, {}
            for n in names or have:
                cols[n], units[n] = _dataset(f, f"{where}/{n}", self.file)
        return Table(MappingProxyType(cols), MappingProxyType(units), f"{self.file}:{where}")


def _open(path: Path):
    h5py = h5py_module()
    if not h5py.is_hdf5(path):
        raise ResultsError(f"{path}: not an HDF5 file, so not the results.h5 of `micropit run`")
    try:
        return h5py.File(path, "r")
    except OSError as e:
        raise ResultsError(f"{path}: cannot be opened as HDF5 (truncated or damaged?): {e}"
                           ) from None


def _dataset(f, name: str, path: Path) -> tuple[np.ndarray, str]:
    """The array and unit of dataset ``name``, or a ResultsError naming it."""
    h5py = h5py_module()
    obj = f.get(name)
    if not isinstance(obj, h5py.Dataset):
        raise ResultsError(f"{path}: dataset {name} is missing" if obj is None else
                           f"{path}: {name} is not a dataset")
    try:
        if h5py.check_string_dtype(obj.dtype) is not None:
            data = np.array(obj.asstr()[()], dtype=str)
        else:
            data = obj[()]
        unit = obj.attrs.get("unit", "")
    except (OSError, ValueError, KeyError, RuntimeError) as e:
        raise ResultsError(f"{path}: dataset {name} cannot be read (damaged file?): {e}"
                           ) from None
    return _frozen(data), _plain(unit)


def _plain(v):
    """An attribute as a plain Python value (str, int, float, or an array)."""
    if isinstance(v, bytes):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return _frozen(v)
    return v


def _group_table(f, name: str, path: Path, required: Sequence[str] = ()) -> Table:
    """Every dataset of group ``name`` (one level), all with the same first axis."""
    h5py = h5py_module()
    g = f.get(name)
    if not isinstance(g, h5py.Group):
        raise ResultsError(f"{path}: group {name}/ is missing")
    for r in required:
        if r not in g:
            raise ResultsError(f"{path}: dataset {name}/{r} is missing")
    cols, units = {}, {}
    for key, obj in g.items():
        if isinstance(obj, h5py.Dataset):
            cols[key], units[key] = _dataset(f, f"{name}/{key}", path)
    lengths = {k: (a.shape[0] if a.ndim else None) for k, a in cols.items()}
    n = lengths.get(required[0]) if required else next(iter(lengths.values()), None)
    odd = [k for k, v in lengths.items() if v != n]
    if odd:
        raise ResultsError(f"{path}: {name}/{odd[0]} has {lengths[odd[0]]} rows, "
                           f"{name}/{required[0] if required else next(iter(cols))} {n}")
    return Table(MappingProxyType(cols), MappingProxyType(units), f"{path}:{name}")


def _kind_hint(f) -> str:
    if "format_version" in f.attrs and "state" in f:
        return " (it looks like a checkpoint, DIR/checkpoints/ckpt_*.h5)"
    if "pressure" in f and "stress_body1" in f:
        return " (it looks like a snapshot of `micropit snapshot`)"
    return ""


def load_summary(path_or_folder: str | Path) -> Table:
    """summary.csv of a run (a file, or the run's folder) as a :class:`Table`: one row per
    item, body and block end; integer, float or text columns as written, units
    :data:`SUMMARY_UNITS` (engineering: µm, GPa, %)."""
    path = Path(path_or_folder)
    if path.is_dir():
        path = path / "summary.csv"
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except OSError as e:
        raise ResultsError(f"{path}: cannot be read: {e.strerror or e}") from None
    except (UnicodeDecodeError, csv.Error) as e:
        raise ResultsError(f"{path}: not a summary.csv of `micropit run`: {e}") from None
    if not rows or "item" not in rows[0] or "Ap_pct" not in rows[0]:
        raise ResultsError(f"{path}: not a summary.csv of `micropit run` (no header with item "
                           "and Ap_pct)")
    header, body = rows[0], rows[1:]
    bad = next((k for k, r in enumerate(body) if len(r) != len(header)), None)
    if bad is not None:
        raise ResultsError(f"{path}: line {bad + 2} has {len(body[bad])} cells, the header "
                           f"{len(header)} (truncated?)")
    cols = {}
    for j, name in enumerate(header):
        cells = [r[j] for r in body]
        for kind in (int, float):
            try:
                cols[name] = _frozen(np.array([kind(c) for c in cells], dtype=kind))
                break
            except ValueError:
                continue
        else:
            cols[name] = _frozen(np.array(cells, dtype=str))
    units = {n: SUMMARY_UNITS.get(n, "") for n in header}
    return Table(MappingProxyType(cols), MappingProxyType(units), str(path))


def load_results(path_or_folder: str | Path) -> Results:
    """Read a run's results.h5 (the file, or the ``--out`` folder of ``micropit run``) and the
    summary.csv beside it. Items, histories, grid and Method B are read now; the maps when
    asked (:meth:`Results.maps`). :class:`ResultsError` when the file is missing, not HDF5,
    truncated, not a results file of ``micropit run``, or lacks a dataset."""
    path = Path(path_or_folder)
    if path.is_dir():
        if not (path / "results.h5").exists():
            raise ResultsError(f"{path}: no results.h5 in this folder (the --out folder of "
                               "`micropit run SCENE --out DIR` holds one once a run finished)")
        path = path / "results.h5"
    elif not path.exists():
        raise ResultsError(f"{path}: no such file or folder")
    with _open(path) as f:
        try:
            attrs, items, history, grid, iso, points, names = _read(f, path)
        except (OSError, KeyError, ValueError, RuntimeError) as e:
            raise ResultsError(f"{path}: cannot be read (truncated or damaged?): {e}") from None
    summary_csv = path.with_name("summary.csv")
    summary = load_summary(summary_csv) if summary_csv.is_file() else None
    return Results(path, MappingProxyType(attrs), items, MappingProxyType(history), grid, iso,
                   MappingProxyType(points), MappingProxyType(names), summary)


def _read(f, path: Path) -> tuple:
    """What :func:`load_results` reads now from the open file ``f``."""
    h5py = h5py_module()
    if not all(g in f for g in ("items", "history", "grid")):
        raise ResultsError(f"{path}: not the results.h5 of `micropit run` (no items/, "
                           f"history/ and grid/ groups){_kind_hint(f)}")
    attrs = {k: _plain(v) for k, v in f.attrs.items()}
    if attrs.get("complete") != 1:
        raise ResultsError(f"{path}: incomplete (no attribute complete = 1: its writer "
                           "stopped before the end)")
    items = _group_table(f, "items", path, ("id",))
    history = {int(i): _group_table(f, f"history/item_{int(i):05d}", path, _REQUIRED_HISTORY)
               for i in items["id"]}
    g = {k: _dataset(f, f"grid/{k}", path)[0] for k in _REQUIRED_GRID}
    grid = Grid(g["x"], g["y"], g["z"], float(g["dx"]), float(g["dy"]))
    iso = None
    if "iso6336_22" in f:
        a = f["iso6336_22"].attrs
        iso = MethodB(_dataset(f, "iso6336_22/roll_angle", path)[0],
                      _dataset(f, "iso6336_22/lambda_GF", path)[0],
                      **{k: (str if k == "summary" else float)(_plain(a[k]))
                         for k in ("lambda_GF_min", "roll_angle_min", "Ra", "lambda_GFT", "W_W",
                                   "lambda_GFP", "S_lambda", "summary") if k in a})
    points = {}
    if "path" in f:
        a = f["path"].attrs
        points = {k: float(a[f"{k}_roll_angle"]) for k in "ABCDE" if f"{k}_roll_angle" in a}
    names: dict[int, tuple[str, ...]] = {}
    for key, grp in (f["maps"].items() if "maps" in f else ()):
        if key.startswith("item_") and key[5:].isdigit() and isinstance(grp, h5py.Group):
            found: list[str] = []
            grp.visititems(lambda n, o, found=found: found.append(n)
                           if isinstance(o, h5py.Dataset) else None)
            names[int(key[5:])] = tuple(sorted(found))
    return attrs, items, history, grid, iso, points, names
