"""Measured maps in a scene (issue 20): the Tukey taper keeps the map's R_q, so a map whose
stated R_q is its own is accepted; the run log says where the spacing came from."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import tiny_doc

from micropit_hpc.errors import SceneError
from micropit_hpc.parallel import SerialComm
from micropit_hpc.plan import make_plan
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.spectral import Grid
from micropit_hpc.study import Study
from micropit_hpc.surfaces import gaussian_surface


def _doc(tmp_path, rq_um, **surface):
    g = Grid(64, 64, 64e-6, 64e-6)
    z = gaussian_surface(g, 0.4e-6, 8e-6, 8e-6, seed=7).heights
    np.savez(tmp_path / "flank.npz", heights=z * 1e6, dx=1.0, dy=1.0, unit="um")
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"] = {"n": 64, "steps": 3, "length_x_um": 64.0, "length_y_um": 64.0}
    doc["stress"] = {"layers": 3}
    doc["body1"]["Rq_um"] = rq_um
    doc["body1"]["surface"] = {"kind": "file", "file": "flank.npz", "height_unit": "um",
                               "detrend": "mean", **surface}
    return doc, z


def test_the_taper_keeps_the_stated_rq_and_the_log_names_the_spacing(tmp_path):
    doc, z = _doc(tmp_path, 0.0)
    doc["body1"]["Rq_um"] = float(z.std() * 1e6)        # the map's own R_q, as a user states it
    log = []
    study = Study(scene_from_dict(doc, str(tmp_path / "s.toml")), SerialComm(), log=log.append)
    study.setup()
    top = study.runs[0].surfaces[0]
    assert top.rq == pytest.approx(z.std(), rel=1e-9)  # before the fix: 14 % low, refused
    assert "periodised tukey(0.1), R_q kept" in top.provenance
    line = [s for s in log if s.startswith("body1.surface: read ")]
    assert len(line) == 1 and "spacing 1e-06 m x 1e-06 m from file" in line[0]


def test_a_scene_spacing_that_overrides_the_files_is_said(tmp_path):
    doc, z = _doc(tmp_path, 0.0, spacing_um=[1.25, 1.25])
    doc["body1"]["Rq_um"] = float(z.std() * 1e6)
    log = []
    study = Study(scene_from_dict(doc, str(tmp_path / "s.toml")), SerialComm(), log=log.append)
    study.setup()
    line = next(s for s in log if s.startswith("body1.surface: read "))
    assert ("spacing 1.25e-06 m x 1.25e-06 m from argument, overriding the file's own 1e-06 m "
            "x 1e-06 m") in line


def test_a_map_smaller_than_the_window_names_the_keys_in_um(tmp_path):
    doc, _ = _doc(tmp_path, 0.4)
    doc["window"]["length_x_um"] = 80.0
    scene = scene_from_dict(doc, str(tmp_path / "s.toml"))
    with pytest.raises(SceneError) as e:     # the plan reads the map: `micropit scene` says it
        make_plan(scene)
    text = str(e.value)
    assert "body1.surface: " in text
    assert "covers 64 µm x 64 µm, smaller than the simulation window 80 µm x 64 µm" in text
    assert "window.length_x_um" in text
