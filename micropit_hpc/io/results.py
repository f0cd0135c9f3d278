"""Results of ``micropit run`` (docs/outputs.md): ``summary.csv`` and ``results.h5``.

Both are written by world rank 0 as ``*.tmp``, flushed, fsynced and renamed, so a crash never
leaves a half-written file under the final name. Engineering units in the CSV (µm, GPa, %); SI
in the HDF5 file, with units in each dataset's ``unit`` attribute.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from micropit_hpc import __version__, source_commit
from micropit_hpc.errors import MicropitError
from micropit_hpc.io.hdf5 import atomic_h5, h5py_module, scene_json
from micropit_hpc.regime import block_flags
from micropit_hpc.report import write_text_atomic

__all__ = ["write_results", "write_summary"]


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
    """results.h5: the items, their block histories and their final maps (docs/outputs.md)."""
    path = Path(path)
    try:
        with atomic_h5(path) as f:
            f.attrs["code_version"] = __version__
            f.attrs["source_commit"] = source_commit()
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
            tab["k_lub"].attrs["unit"] = "s"
            tab["roughness_scale"] = np.array([i.scale for i in items])
            tab["patch"] = np.array([i.patch for i in items])
            conds = [study.base.conditions[i.position - 1] for i in items]
            tab["S"] = np.array([c.S for c in conds])
            tab["p0"] = np.array([c.p0 for c in conds])
            tab["p0"].attrs["unit"] = "Pa"
            tab["Lambda"] = np.array([study.item_lambda(i) for i in items])
            tab["lambda_GF"] = np.array([study.item_lambda_gf(i) for i in items])
            tab["hc"] = np.array([c.hc for c in conds])
            tab["hc"].attrs["unit"] = "m"
            tab["single_pair"] = np.array([c.region == "single" for c in conds], dtype=np.uint8)
            tab["roll_angle"] = np.array([c.roll_angle for c in conds])   # NaN for a disc rig
            tab["roll_angle"].attrs["unit"] = "rad"
            tab["radial_position"] = np.array([c.radial_position for c in conds])
            tab["radial_position"].attrs["unit"] = "m"
            f.attrs["window_problems"] = "; ".join(study.window_problems) or "none"
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
                g["flags"].attrs["description"] = ("per block: flags outside the model's range "
                                                   "(docs/life.md, \"The model's range\")")
            mg = f.create_group("maps")
            for iid, m in maps.items():
                g = mg.create_group(f"item_{iid:05d}")
                for name, arr in m.items():
                    g.create_dataset(name, data=arr, compression="gzip", compression_opts=4,
                                     shuffle=True)
            grid, z = study.window()
            f["grid/z"] = z
            f["grid/z"].attrs["unit"] = "m"
            f["grid/dx"] = grid.dx
            f["grid/dy"] = grid.dy
            f.attrs["complete"] = 1
    except OSError as e:
        raise MicropitError(f"cannot write {path}: {e.strerror or e}") from None
    return path
