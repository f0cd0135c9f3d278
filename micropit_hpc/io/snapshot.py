"""``micropit snapshot``: one time step of one position as an HDF5 file (see docs/outputs.md).

Written by one rank to ``<out>/snapshot.h5.tmp``, flushed, fsynced and renamed, so a crash
never leaves a half-written file under the final name.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np

from micropit_hpc import __version__, source_commit
from micropit_hpc.io.hdf5 import atomic_h5, scene_json

VOIGT = "xx,yy,zz,yz,xz,xy"


def write_snapshot(path: str | Path, cycle, fields, stresses: dict[int, np.ndarray]) -> Path:
    """Write one step: pressure, clearance, solid-contact mask, friction, tractions, the
    topographies in each body's material frame and the stress tensor per layer and body."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    g, c = cycle.grid, cycle.cond
    with atomic_h5(path) as f:
        a = f.attrs
        a["format"] = "micropit_hpc snapshot 1"
        a["code_version"] = __version__
        a["source_commit"] = source_commit()
        a["created_utc"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
        a["scene"] = scene_json(cycle.scene.document)
        a["scene_file"] = cycle.scene.source
        for k, v in (("position", cycle.position), ("step", fields.step),
                     ("steps", cycle.steps), ("t_s", fields.t), ("x_c_m", fields.x_c),
                     ("p_mean_Pa", fields.p_mean), ("phi", fields.phi),
                     ("iterations", fields.iterations), ("b_m", c.b), ("p0_Pa", c.p0),
                     ("b_ref_m", cycle.b_ref), ("u1_m_s", c.u1), ("u2_m_s", c.u2),
                     ("S", c.S), ("hc_m", c.hc), ("Lambda", c.Lambda)):
            a[k] = v
        a["level"] = fields.level
        a["frames"] = ("window frame for the contact fields; stress_body<i>, height_body<i>, "
                       "pressure_material_body<i> and traction_material_body<i> in the "
                       "material frame of body i")

        def put(name, data, unit, doc):
            d = f.create_dataset(name, data=data)
            d.attrs["unit"] = unit
            d.attrs["description"] = doc

        put("x", g.x, "m", "window x (rolling), point centres")
        put("y", g.y, "m", "window y (across rolling)")
        put("z", cycle.z, "m", "depth of each stress layer")
        put("pressure", fields.pressure, "Pa", "contact pressure")
        put("clearance", fields.clearance, "m", "gap between the deformed surfaces")
        put("solid_contact", fields.solid.astype(np.uint8), "1", "1 where in solid contact")
        put("friction", fields.friction, "1", "local friction coefficient")
        for i in (1, 2):
            put(f"traction_body{i}", getattr(fields, f"traction{i}"), "Pa",
                f"friction traction on body {i} along +x")
            p_mat, q_mat = cycle.material_tractions(fields, i)
            put(f"pressure_material_body{i}", p_mat, "Pa",
                f"contact pressure in body {i}'s material frame (the stresses' frame: "
                f"stress_body{i}[zz, 0] = -this averaged over fatigue.process_length_um)")
            put(f"traction_material_body{i}", q_mat, "Pa",
                f"friction traction on body {i} along +x in its material frame "
                f"(stress_body{i}[xz, 0] = -this averaged over fatigue.process_length_um)")
            put(f"height_body{i}", cycle.surfaces[i - 1].heights, "m",
                f"topography of body {i}, outward positive")
        for i, s in stresses.items():
            d = f.create_dataset(f"stress_body{i}", data=s, compression="gzip",
                                 compression_opts=1, shuffle=True)
            d.attrs["unit"] = "Pa"
            d.attrs["components"] = VOIGT
            d.attrs["description"] = ("stress tensor (tension positive) per component, "
                                      "layer, x, y in body's material frame")
    return path
