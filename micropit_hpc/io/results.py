"""Results of ``micropit run`` (docs/outputs.md): ``summary.csv`` and ``results.h5``.

Both are written by world rank 0 as ``*.tmp``, flushed, fsynced and renamed, so a crash never
leaves a half-written file under the final name. Engineering units in the CSV (µm, GPa, %); SI
in the HDF5 file, with the unit of every dataset in its ``unit`` attribute ("1" for a pure
number), the window's coordinates in ``grid/x``, ``grid/y``, ``grid/z``, and an XDMF file
(``results.xdmf``, :func:`write_xdmf`) beside it so that ParaView and VisIt open the maps.
Provenance: the code's commit, the library versions and the SHA-256 of the input files
(:mod:`micropit_hpc.io.provenance`).
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from micropit_hpc import __version__, source_commit
from micropit_hpc.errors import MicropitError
from micropit_hpc.io.atomic import write_text_atomic
from micropit_hpc.io.hdf5 import atomic_h5, h5py_module, scene_json
from micropit_hpc.regime import block_flags

__all__ = ["MAP_UNITS", "write_results", "write_summary", "write_xdmf"]

#: Unit of each final map (``maps/item_NNNNN/bodyB/<name>``).
MAP_UNITS = {"heights": "m", "damage": "1", "damage_risk": "1", "pitted": "1", "wear": "m",
             "pit_depth": "m"}
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
                for name, unit in (("block", "1"), ("cycles", "1"), ("sub_blocks", "1"),
                                   ("phi", "1"), ("wall_s", "s"), ("Ap", "%"),
                                   ("max_damage", "1"), ("wear_mean", "m"), ("wear_max", "m"),
                                   ("Rq", "m"), ("n_micro", "1"), ("wear_step", "1"),
                                   ("pit_step", "1"), ("low_cycle_damage", "1"),
                                   ("low_cycle_pits", "1"), ("plastic_share", "1"),
                                   ("deep_damage", "1"), ("slope", "rad"),
                                   ("pit_depth_max", "m")):
                    g[name] = np.array([getattr(r, name) for r in recs])  # (blocks[, 2 bodies])
                    g[name].attrs["unit"] = unit
                flags = [";".join(block_flags(r, study.z_max, not study.window_problems))
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
            grid, z = study.window()
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
        surf = [n for n in names if not n.endswith("/damage")]
        vol = [n for n in names if n.endswith("/damage")]
        out += [f'    <Grid Name="item_{iid:05d}_surface" GridType="Uniform">',
                f'      <Topology TopologyType="2DRectMesh" Dimensions="{nx} {ny}"/>',
                '      <Geometry GeometryType="VXVY">',
                "        " + item(str(ny), "f8", "/grid/y"),
                "        " + item(str(nx), "f8", "/grid/x"),
                "      </Geometry>"]
        for n in surf:
            dtype = "u1" if n.endswith("/pitted") else "f8"
            unit = MAP_UNITS[n.split("/")[-1]]
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
                out += [f'      <Attribute Name="{n.replace("/", "_")} [1]" '
                        'AttributeType="Scalar" Center="Node">',
                        "        " + item(f"{nz} {nx} {ny}", "f8", f"{base}/{n}"),
                        "      </Attribute>"]
            out.append("    </Grid>")
    out += ["  </Domain>", "</Xdmf>", ""]
    write_text_atomic(xdmf, "\n".join(out))
    return xdmf
