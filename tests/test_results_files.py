"""results.h5 as a gear engineer's tools read it (issue 20): units on every dataset, x/y/z
coordinates, the XDMF file beside it, library versions and input-file hashes."""

from __future__ import annotations

import hashlib
import json
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from helpers import tiny_doc, write_scene

from micropit_hpc.cli import main


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("res")
    doc = tiny_doc(slide_roll=(0.3,))
    doc["life"] = {"cycles_M": 1.0, "block_M": 1.0, "max_splits": 2}
    doc["window"] = {"n": 16, "ny": 12, "steps": 3}
    doc["stress"] = {"layers": 3}
    doc["lubricant"]["lambda_GFT"] = 0.3
    scene = write_scene(tmp / "tiny.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp / "out"), "--quiet"]) == 0
    return tmp


@pytest.mark.slow
def test_every_dataset_has_a_unit_and_the_grid_has_coordinates(run_dir):
    missing = []
    with h5py.File(run_dir / "out" / "results.h5", "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and "unit" not in obj.attrs:
                missing.append(name)
        f.visititems(visit)
        x, y, z = f["grid/x"][()], f["grid/y"][()], f["grid/z"][()]
        assert x.shape == (16,) and y.shape == (12,) and z.shape == (3,)
        np.testing.assert_allclose(np.diff(x), f["grid/dx"][()])
        np.testing.assert_allclose(np.diff(y), f["grid/dy"][()])
        assert f["grid/x"].attrs["unit"] == "m" and f["maps/item_00000/body1/heights"].attrs[
            "unit"] == "m"
        assert f["maps/item_00000/body1/heights"].shape == (16, 12)
        assert f["maps/item_00000/body1/damage"].shape == (3, 16, 12)
        assert f["maps/item_00000/body2/damage_risk"].attrs["unit"] == "1"
    assert missing == []


@pytest.mark.slow
def test_the_xdmf_references_every_map_with_its_shape(run_dir):
    """Parse results.xdmf as any XDMF reader does and read every referenced dataset."""
    xdmf = run_dir / "out" / "results.xdmf"
    root = ET.parse(xdmf).getroot()
    assert root.tag == "Xdmf" and root.get("Version") == "3.0"
    grids = root.findall("./Domain/Grid")
    assert {g.get("Name") for g in grids} == {"item_00000_surface", "item_00000_damage"}
    seen = set()
    with h5py.File(run_dir / "out" / "results.h5", "r") as f:
        for g in grids:
            topo = g.find("Topology")
            dims = tuple(int(d) for d in topo.get("Dimensions").split())
            geo = [int(d.get("Dimensions")) for d in g.find("Geometry").findall("DataItem")]
            # VXVY(VZ): one coordinate array per axis, fastest (X) first
            assert tuple(reversed(geo)) == dims
            for item in g.iter("DataItem"):
                file, where = item.text.strip().split(":")
                assert (xdmf.parent / file).resolve() == (run_dir / "out" / "results.h5"
                                                          ).resolve()
                data = f[where][()]
                shape = tuple(int(d) for d in item.get("Dimensions").split())
                assert data.shape == shape, where
                assert data.dtype.itemsize == int(item.get("Precision"))
                assert (item.get("NumberType") == "Float") == (data.dtype.kind == "f")
                seen.add(where)
            for att in g.findall("Attribute"):
                assert att.find("DataItem").get("Dimensions") == topo.get("Dimensions")
    maps = {f"/maps/item_00000/body{b}/{n}" for b in (1, 2)
            for n in ("heights", "damage", "damage_risk", "pitted", "wear", "pit_depth")}
    assert maps | {"/grid/x", "/grid/y", "/grid/z"} == seen


@pytest.mark.slow
def test_provenance_names_the_libraries_and_hashes_the_inputs(run_dir):
    import numpy
    import scipy

    with h5py.File(run_dir / "out" / "results.h5", "r") as f:
        libs = json.loads(f.attrs["library_versions"])
        hashes = json.loads(f.attrs["input_sha256"])
        # the criterion's length the run used: the adaptive integration's default, resolved
        assert f.attrs["process_length_m"] == pytest.approx(5e-6, rel=1e-12, abs=0)
        iso = f["iso6336_22"]
        assert iso.attrs["lambda_GFT"] == 0.3
        assert iso.attrs["lambda_GFP"] == pytest.approx(0.42)
        assert iso.attrs["S_lambda"] == pytest.approx(iso.attrs["lambda_GF_min"] / 0.42)
        np.testing.assert_allclose(f["items/S_lambda"][()], f["items/lambda_GF"][()] / 0.42)
    assert libs["numpy"] == numpy.__version__ and libs["scipy"] == scipy.__version__
    assert libs["h5py"] == h5py.__version__ and libs["hdf5"] == h5py.version.hdf5_version
    for name in ("mpi4py", "petsc4py", "pyfftw", "mpi_library", "python"):
        assert libs.get(name) not in (None, "missing"), name
    scene = run_dir / "tiny.toml"
    assert hashes == {str(scene): hashlib.sha256(scene.read_bytes()).hexdigest()}


def test_a_measured_map_is_hashed(tmp_path):
    from micropit_hpc.io.provenance import input_hashes
    from micropit_hpc.scene import scene_from_dict

    doc = tiny_doc()
    (tmp_path / "map.npy").write_bytes(b"not really a map")
    doc["body1"]["surface"] = {"kind": "file", "file": "map.npy", "spacing_um": [1.0, 1.0]}
    scene = scene_from_dict(doc, str(tmp_path / "s.toml"))
    hashes = input_hashes(scene)
    assert hashes[str(tmp_path / "map.npy")] == hashlib.sha256(b"not really a map").hexdigest()
    assert hashes[str(tmp_path / "s.toml")] == "unreadable"      # never written here
