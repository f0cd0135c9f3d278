"""micropit_hpc.io.results.load_results: a run's results.h5 (and summary.csv) read back into
frozen dataclasses, checked against the file as h5py sees it and against summary.csv; the clear
errors for what is not such a file; the postprocess scripts on it."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers import tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.errors import MicropitError
from micropit_hpc.io.results import (
    ResultsError,
    Table,
    load_results,
    load_summary,
)

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A tiny disc study run for real: 2 slide-roll ratios, 2 blocks, a 16 × 12 window with 3
    layers."""
    tmp = tmp_path_factory.mktemp("load")
    doc = tiny_doc(slide_roll=(0.1, 0.3))
    doc["life"] = {"cycles_M": 2.0, "block_M": 1.0, "max_splits": 1}
    doc["window"] = {"n": 16, "ny": 12, "steps": 3}
    doc["stress"] = {"layers": 3}
    for body in ("body1", "body2"):       # wider than the window holds: window_problems
        doc[body]["surface"]["corr_y_um"] = 300.0
    scene = write_scene(tmp / "tiny.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp / "out"), "--quiet"]) == 0
    return tmp / "out"


def _raw(f, name):
    d = f[name]
    data = d.asstr()[()] if h5py.check_string_dtype(d.dtype) else d[()]
    return np.asarray(data), d.attrs["unit"]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind in "fc":
        return a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    return a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.slow
def test_every_dataset_and_attribute_reads_back_as_written(run_dir):
    res = load_results(run_dir)
    assert res.file == run_dir / "results.h5" and res.folder == run_dir
    assert load_results(run_dir / "results.h5").ids == res.ids == [0, 1]
    with h5py.File(run_dir / "results.h5", "r") as f:
        assert set(res.attrs) == set(f.attrs)
        for k, v in f.attrs.items():
            got = res.attrs[k]
            assert _same(got, v) if isinstance(v, np.ndarray) else got == v, k
        assert set(res.items) == set(f["items"])
        for k in f["items"]:
            data, unit = _raw(f, f"items/{k}")
            assert _same(res.items[k], data) and res.items.units[k] == unit, k
        assert set(res.history) == {0, 1}
        for iid, table in res.history.items():
            g = f"history/item_{iid:05d}"
            assert set(table) == set(f[g])
            for k in f[g]:
                data, unit = _raw(f, f"{g}/{k}")
                assert _same(table[k], data) and table.units[k] == unit, (g, k)
        for k in ("x", "y", "z", "dx", "dy"):
            assert _same(getattr(res.grid, k), f[f"grid/{k}"][()]) and res.grid.unit == "m"
        iso = f["iso6336_22"]
        assert _same(res.iso6336_22.roll_angle, iso["roll_angle"][()])
        assert _same(res.iso6336_22.lambda_GF, iso["lambda_GF"][()])
        for k in ("lambda_GF_min", "roll_angle_min", "Ra", "lambda_GFT", "W_W", "lambda_GFP",
                  "S_lambda", "summary"):
            assert _same(getattr(res.iso6336_22, k), iso.attrs[k]), k
        for iid in res.ids:
            for body in (1, 2):
                maps = res.maps(iid, body)
                g = f"maps/item_{iid:05d}/body{body}"
                assert set(maps) == set(f[g]) == {"heights", "damage", "damage_risk", "pitted",
                                                  "wear", "pit_depth"}
                for k in f[g]:
                    data, unit = _raw(f, f"{g}/{k}")
                    assert _same(maps[k], data) and maps.units[k] == unit, (g, k)
    assert res.path_points == {}                                   # a disc rig: no A–E


@pytest.mark.slow
def test_shapes_units_and_the_summary_agree(run_dir):
    res = load_results(run_dir)
    assert res.status == "done" and res.scene["study"]["name"] == "tiny"
    assert res.scene_file.endswith("tiny.toml")
    # the tiny window is narrower than twice corr_y: both bodies' problems, one string each
    assert len(res.window_problems) == 2 and "; ".join(res.window_problems) == \
        res.attrs["window_problems"] and "body1.surface.corr_y_um" in res.window_problems[0]
    assert "numpy" in res.library_versions and len(res.input_sha256) == 1
    assert res.grid.shape == (16, 12) and res.grid.z.shape == (3,)
    assert res.items.rows == 2 and res.items.units["p0"] == "Pa"
    assert res.items.units["roll_angle"] == "rad" and np.isnan(res.items["roll_angle"]).all()
    h = res.history[1]
    assert h.rows == 2 and h["Ap"].shape == (2, 2) and h.units["Ap"] == "%"
    assert h["cycles"].tolist() == [1e6, 2e6] and h.units["wear_mean"] == "m"
    assert h["flags"].dtype.kind == "U" and all(isinstance(s, str) for s in h["flags"].tolist())
    m = res.maps(1, 2, "heights", "damage")
    assert list(m) == ["heights", "damage"] and m.units["heights"] == "m"
    assert m["heights"].shape == (16, 12) and m["damage"].shape == (3, 16, 12)
    # summary.csv, written apart from results.h5 from the same records (engineering units)
    s = res.summary
    assert s is not None and s.rows == 2 * 2 * 2 and s.units["Ap_pct"] == "%"
    assert s["item"].dtype.kind == "i" and s["flags"].dtype.kind == "U"
    assert all(s.units[c] for c in s if c != "flags")      # every column has its unit
    assert load_summary(run_dir / "summary.csv")["cycles"].tolist() == s["cycles"].tolist()
    for iid in res.ids:
        for body in (1, 2):
            rows = (s["item"] == iid) & (s["body"] == body)
            np.testing.assert_allclose(s["Ap_pct"][rows], res.history[iid]["Ap"][:, body - 1],
                                       rtol=1e-5, atol=1e-9)
            np.testing.assert_allclose(s["cycles"][rows], res.history[iid]["cycles"])
            k = res.ids.index(iid)
            np.testing.assert_allclose(s["p0_GPa"][rows], res.items["p0"][k] / 1e9, rtol=1e-5)
            assert (s["flags"][rows] == res.history[iid]["flags"]).all()
            pitted = res.maps(iid, body, "pitted")["pitted"]
            assert 100 * pitted.mean() == pytest.approx(res.history[iid]["Ap"][-1, body - 1])


@pytest.mark.slow
def test_the_results_are_frozen(run_dir):
    res = load_results(run_dir)
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.items = None
    with pytest.raises(ValueError):
        res.history[0]["Ap"][0, 0] = 5.0                         # read-only arrays
    with pytest.raises(TypeError):
        res.history[7] = res.history[0]
    with pytest.raises(KeyError, match="no 'nope'"):
        res.items["nope"]
    assert isinstance(res.items, Table)
    assert repr(res) == (f"Results({run_dir / 'results.h5'}: 2 items, 2 blocks, status done)")
    assert repr(res.items).startswith(f"Table({run_dir / 'results.h5'}:items: 2 rows; ")


def _broken(run_dir, tmp_path, change) -> Path:
    """A copy of the run's results.h5 (and summary.csv) with ``change(h5py.File)`` applied."""
    out = tmp_path / "broken"
    out.mkdir()
    shutil.copy(run_dir / "results.h5", out / "results.h5")
    with h5py.File(out / "results.h5", "r+") as f:
        change(f)
    return out


@pytest.mark.slow
@pytest.mark.parametrize(("change", "message"), [
    (lambda f: f.__delitem__("history/item_00001/Ap"), "dataset history/item_00001/Ap is missing"),
    (lambda f: f.__delitem__("grid/z"), "dataset grid/z is missing"),
    (lambda f: f.__delitem__("items/id"), "dataset items/id is missing"),
    (lambda f: f.__delitem__("history/item_00000"), "group history/item_00000/ is missing"),
    (lambda f: f.attrs.__delitem__("complete"), "incomplete (no attribute complete = 1"),
    (lambda f: f.__delitem__("items"), "not the results.h5 of `micropit run`"),
])
def test_a_missing_part_is_named(run_dir, tmp_path, change, message):
    out = _broken(run_dir, tmp_path, change)
    with pytest.raises(ResultsError) as e:
        load_results(out)
    assert str(e.value).startswith(f"{out / 'results.h5'}: ") and message in str(e.value)
    assert isinstance(e.value, MicropitError)


@pytest.mark.slow
def test_a_missing_map_is_named(run_dir, tmp_path):
    out = _broken(run_dir, tmp_path, lambda f: f.__delitem__("maps/item_00001/body2/wear"))
    res = load_results(out)
    with pytest.raises(ResultsError, match=r"maps/item_00001/body2 has no wear \(it has "):
        res.maps(1, 2, "wear")
    assert set(res.maps(1, 2)) == {"heights", "damage", "damage_risk", "pitted", "pit_depth"}
    with pytest.raises(ResultsError, match="no maps of item 5, body 1"):
        res.maps(5, 1)


@pytest.mark.slow
def test_not_a_results_file(run_dir, tmp_path):
    with pytest.raises(ResultsError, match="no such file or folder"):
        load_results(tmp_path / "nothing")
    with pytest.raises(ResultsError, match=f"{tmp_path}: no results.h5 in this folder"):
        load_results(tmp_path)
    text = tmp_path / "text" / "results.h5"
    text.parent.mkdir()
    text.write_text("item,position\n0,1\n")
    with pytest.raises(ResultsError, match=f"{text}: not an HDF5 file"):
        load_results(text.parent)
    ckpt = sorted((run_dir / "checkpoints").glob("ckpt_*.h5"))[-1]
    with pytest.raises(ResultsError, match="not the results.h5 .* looks like a checkpoint"):
        load_results(ckpt)
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["data"] = np.zeros(3)
    with pytest.raises(ResultsError, match=r"other.h5: not the results.h5 of `micropit run` "
                                           r"\(no items/, history/ and grid/ groups\)$"):
        load_results(tmp_path / "other.h5")


@pytest.mark.slow
@pytest.mark.parametrize("keep", [0.05, 0.5, 0.9])
def test_a_truncated_file_is_a_clear_error(run_dir, tmp_path, keep):
    data = (run_dir / "results.h5").read_bytes()
    cut = tmp_path / "results.h5"
    cut.write_bytes(data[:int(len(data) * keep)])
    with pytest.raises(ResultsError, match=f"^{cut}: .*truncated or damaged"):
        res = load_results(tmp_path)
        for iid in res.ids:                  # the maps are read when asked: may fail there
            res.maps(iid, 1)
            res.maps(iid, 2)


@pytest.mark.slow
def test_a_truncated_summary_is_a_clear_error(run_dir, tmp_path):
    text = (run_dir / "summary.csv").read_text()
    # cut a line in the middle of the file just after its second cell (a cut at a fixed
    # character could land in the last cell, which leaves the count of cells whole)
    middle = text.index("\n", len(text) // 2) + 1
    cut = text.index(",", text.index(",", middle) + 1) + 1
    (tmp_path / "summary.csv").write_text(text[:cut])
    with pytest.raises(ResultsError, match=r"summary.csv: line \d+ has \d+ cells"):
        load_summary(tmp_path)
    (tmp_path / "summary.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ResultsError, match="not a summary.csv of `micropit run`"):
        load_summary(tmp_path / "summary.csv")


def test_io_needs_neither_report_nor_the_physics():
    """io/ imports no report.py (and so not the contact, film and fatigue modules behind it)."""
    code = ("import sys, micropit_hpc.io.results, micropit_hpc.io.checkpoint, "
            "micropit_hpc.io.outdir, micropit_hpc.io.snapshot; "
            "print(sorted(m for m in sys.modules if m.startswith('micropit_hpc.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=60, check=True).stdout
    assert "micropit_hpc.report" not in out and "micropit_hpc.conditions" not in out, out
    from micropit_hpc import report
    from micropit_hpc.io.atomic import write_text_atomic
    assert report.write_text_atomic is write_text_atomic      # still importable from report


def test_postprocess_scripts_need_no_h5py():
    for script in sorted((ROOT / "postprocess").glob("*.py")):
        text = script.read_text()
        assert "import h5py" not in text and "h5py." not in text, script.name


@pytest.mark.slow
def test_the_plot_scripts_run_on_a_real_run(run_dir, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(run_dir, run, ignore=shutil.ignore_patterns("checkpoints"))
    out = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_life.py"), str(run),
                          "--max-items", "1"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert (run / "life.png").stat().st_size > 10_000
    out = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_flank.py"), str(run)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 1 and "is not a gear flank study" in out.stderr  # a disc rig
    (run / "results.h5").write_bytes(b"not hdf5")
    out = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_life.py"), str(run)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and out.stderr.startswith("plot_life: ") and "not an HDF5 file" \
        in out.stderr
