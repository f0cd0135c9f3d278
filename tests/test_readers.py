"""Height-map readers: round trips of the built-in formats, every error case, NaN policies and
the optional SurfaceTopography adapter (through a fake module)."""

from __future__ import annotations

import sys
import types

import h5py
import numpy as np
import pytest

from micropit_hpc.surfaces import TopographyError, read_topography

UM = 1e-6
RNG = np.random.default_rng(2024)
H = RNG.standard_normal((7, 5)) * 0.4  # in the unit the test stores them in


def msg_of(path, **kwargs) -> str:
    with pytest.raises(TopographyError) as err:
        read_topography(path, **kwargs)
    text = str(err.value)
    assert "\n" not in text and str(path) in text
    return text


# ---- round trips ----------------------------------------------------------------------------
def test_npy_round_trip_needs_a_spacing(tmp_path):
    p = tmp_path / "map.npy"
    np.save(p, H * UM)
    t = read_topography(p, spacing=(0.5 * UM, 2 * UM))
    assert np.array_equal(t.heights, H * UM) and (t.dx, t.dy) == (0.5 * UM, 2 * UM)
    assert str(p) in t.provenance and "spacing 5e-07 m x 2e-06 m from argument" in t.provenance
    assert "spacing=(dx, dy)" in msg_of(p)


def test_npz_round_trip_with_spacing_and_its_unit(tmp_path):
    p = tmp_path / "map.npz"
    np.savez(p, heights=H, dx=0.25, dy=1.5, unit="um")
    t = read_topography(p, height_unit="um")
    assert np.array_equal(t.heights, H * 1e-6)
    assert (t.dx, t.dy) == (0.25 * 1e-6, 1.5 * 1e-6)
    q = tmp_path / "plain.npz"
    np.savez(q, heights=H * UM, dx=UM, dy=2 * UM, other=np.zeros(3))
    t = read_topography(q)
    assert np.array_equal(t.heights, H * UM) and (t.dx, t.dy) == (UM, 2 * UM)
    t = read_topography(q, spacing=(3 * UM, 4 * UM))  # the argument overrides the file
    assert (t.dx, t.dy) == (3 * UM, 4 * UM)
    r = tmp_path / "named.npz"
    np.savez(r, z=H)
    assert np.array_equal(read_topography(r, dataset="z", spacing=(UM, UM)).heights, H)
    assert "no array 'heights' (arrays in the file: z)" in msg_of(r, spacing=(UM, UM))
    s = tmp_path / "half.npz"
    np.savez(s, heights=H, dx=UM)
    assert "only one of the arrays dx, dy" in msg_of(s)


@pytest.mark.parametrize("name,delimiter", [("m.txt", " "), ("m.csv", ","), ("m.dat", "\t")])
def test_text_matrix_round_trip(tmp_path, name, delimiter):
    p = tmp_path / name
    np.savetxt(p, H, delimiter=delimiter, fmt="%.17g", header="heights in nm")
    t = read_topography(p, spacing=(UM, 2 * UM), height_unit="nm")
    assert np.array_equal(t.heights, H * 1e-9) and t.heights.shape == (7, 5)
    assert "spacing=(dx, dy)" in msg_of(p)


def test_hdf5_round_trip_with_attributes(tmp_path):
    p = tmp_path / "map.h5"
    with h5py.File(p, "w") as f:
        d = f.create_dataset("scan/heights", data=H * UM)
        d.attrs["dx"], d.attrs["dy"] = 0.5 * UM, 0.75 * UM
        f.create_dataset("scan/x", data=np.arange(7.0))  # 1-D: not a candidate
    t = read_topography(p)
    assert np.array_equal(t.heights, H * UM) and (t.dx, t.dy) == (0.5 * UM, 0.75 * UM)
    assert "[scan/heights]" in t.provenance
    q = tmp_path / "root_attrs.hdf5"
    with h5py.File(q, "w") as f:
        f.create_dataset("z", data=H)
        f.attrs["dx"], f.attrs["dy"], f.attrs["unit"] = 2.0, 4.0, "mm"
    t = read_topography(q, dataset="/z", height_unit="mm")
    assert np.array_equal(t.heights, H * 1e-3) and (t.dx, t.dy) == (2e-3, 4e-3)


def test_hdf5_dataset_choice_and_errors(tmp_path):
    p = tmp_path / "two.h5"
    with h5py.File(p, "w") as f:
        f["a"], f["b"], f["c"] = H, H.T, np.zeros(3)
    assert np.array_equal(read_topography(p, dataset="b", spacing=(UM, UM)).heights, H.T)
    text = msg_of(p, spacing=(UM, UM))
    assert "2 2-D datasets, pass dataset=" in text and "a (7, 5), b (5, 7), c (3,)" in text
    text = msg_of(p, dataset="heights", spacing=(UM, UM))
    assert "dataset 'heights' not found (datasets in the file: a, b, c)" in text
    assert "shape (3,): must be a 2-D map" in msg_of(p, dataset="c", spacing=(UM, UM))
    q = tmp_path / "bad_attr.h5"
    with h5py.File(q, "w") as f:
        f["z"] = H
        f["z"].attrs["dx"], f["z"].attrs["dy"] = -1e-6, 1e-6
    assert "[z]: attribute dx = -1e-06 m: must be positive and finite" in msg_of(q)
    r = tmp_path / "no_spacing.h5"
    with h5py.File(r, "w") as f:
        f["z"] = H
    assert "[z]: the .h5 file gives no grid spacing: pass spacing=(dx, dy)" in msg_of(r)


# ---- errors ---------------------------------------------------------------------------------
def test_missing_and_unreadable_files(tmp_path):
    assert "file not found" in msg_of(tmp_path / "nothere.npy", spacing=(UM, UM))
    assert "not a regular file" in msg_of(tmp_path, spacing=(UM, UM))
    for name in ("bad.npy", "bad.npz", "bad.h5", "bad.csv"):
        p = tmp_path / name
        p.write_bytes(b"\x00\x01garbage,not,a,number\n")
        assert f"cannot read it as {p.suffix}" in msg_of(p, spacing=(UM, UM))


@pytest.mark.parametrize("array,words", [
    (np.zeros(6), "shape (6,): must be a 2-D map"),
    (np.zeros((2, 3, 4)), "shape (2, 3, 4): must be a 2-D map"),
    (np.zeros((1, 6)), "shape (1, 6) are a single row"),
    (np.zeros((6, 1)), "shape (6, 1) are a single column"),
    (np.array([["a", "b"], ["c", "d"]]), "dtype <U1: not numeric"),
])
def test_maps_that_are_not_2d_grids(tmp_path, array, words):
    p = tmp_path / "m.npy"
    np.save(p, array)
    assert words in msg_of(p, spacing=(UM, UM))


def test_single_row_and_column_text_files(tmp_path):
    p = tmp_path / "row.txt"
    p.write_text("1 2 3 4\n")
    assert "a single row" in msg_of(p, spacing=(UM, UM))
    p = tmp_path / "col.csv"
    p.write_text("1\n2\n3\n")
    assert "a single column" in msg_of(p, spacing=(UM, UM))


@pytest.mark.parametrize("spacing,words", [
    ((0.0, UM), "spacing dx = 0.0 m: must be positive and finite"),
    ((UM, -UM), "spacing dy = -1e-06 m: must be positive and finite"),
    ((UM, np.nan), "spacing dy = nan m"),
    ((UM,), "must be two numbers (dx, dy) in metres"),
    (UM, "must be two numbers (dx, dy) in metres"),
])
def test_bad_spacing_argument(tmp_path, spacing, words):
    p = tmp_path / "m.npy"
    np.save(p, H)
    assert words in msg_of(p, spacing=spacing)


def test_bad_options(tmp_path):
    p = tmp_path / "m.npy"
    np.save(p, H)
    text = msg_of(p, spacing=(UM, UM), height_unit="inch")
    assert "height_unit = 'inch': unknown unit (allowed: m, mm, um" in text
    text = msg_of(p, spacing=(UM, UM), nan_policy="zero")
    assert "nan_policy = 'zero': unknown (allowed: error, fill_mean, interpolate)" in text


def test_unknown_extension_without_surfacetopography(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "SurfaceTopography", None)  # import fails
    p = tmp_path / "scan.x3p"
    p.write_bytes(b"PK\x03\x04")
    text = msg_of(p)
    assert "unknown extension '.x3p'" in text and ".npy, .npz, .txt, .csv, .dat, .h5" in text
    # the advice installs it without replacing NumPy or h5py (issue 20)
    assert "scripts/install-surfaces.sh" in text and "docs/install.md" in text and ".sdf" in text
    assert "a plain `pip install` would replace NumPy" in text


# ---- NaN policies ---------------------------------------------------------------------------
def holed(tmp_path, h):
    p = tmp_path / "holes.npy"
    np.save(p, h)
    return p


def test_nan_policy_error_counts_the_points(tmp_path):
    h = H.copy()
    h[2, 3] = h[4, 0] = np.nan
    h[6, 4] = np.inf
    text = msg_of(holed(tmp_path, h), spacing=(UM, UM))
    assert "3 of 35 points (8.57%) are NaN or inf" in text and "nan_policy='fill_mean'" in text


def test_fill_mean(tmp_path):
    h = H.copy()
    h[2, 3] = h[4, 0] = np.nan
    t = read_topography(holed(tmp_path, h), spacing=(UM, UM), nan_policy="fill_mean")
    valid = np.isfinite(h)
    assert np.array_equal(t.heights[valid], h[valid])
    assert t.heights[2, 3] == t.heights[4, 0] == pytest.approx(np.mean(h[valid]), rel=1e-15)
    assert "2 of 35 points" in t.provenance and "fill_mean" in t.provenance


def test_interpolation_is_exact_for_a_plane_and_nearest_at_the_edge(tmp_path):
    x, y = np.meshgrid(np.arange(20) * 2.0, np.arange(12) * 0.5, indexing="ij")
    plane = 1.0 + 0.3 * x - 0.7 * y
    h = plane.copy()
    h[5:9, 4:7] = np.nan  # a hole inside: linear interpolation reproduces the plane
    h[12, 2] = np.nan
    t = read_topography(holed(tmp_path, h), spacing=(2.0, 0.5), nan_policy="interpolate")
    np.testing.assert_allclose(t.heights, plane, atol=1e-12)
    h = plane.copy()
    h[:, -1] = np.nan  # a missing edge column lies outside the hull: nearest neighbour
    t = read_topography(holed(tmp_path, h), spacing=(2.0, 0.5), nan_policy="interpolate")
    assert np.array_equal(t.heights[:, -1], plane[:, -2])
    assert np.array_equal(t.heights[:, :-1], plane[:, :-1])


@pytest.mark.parametrize("policy", ["error", "fill_mean", "interpolate"])
def test_a_map_without_valid_points_is_always_an_error(tmp_path, policy):
    text = msg_of(holed(tmp_path, np.full((4, 4), np.nan)), spacing=(UM, UM), nan_policy=policy)
    assert "all 16 points are NaN or inf" in text


# ---- SurfaceTopography adapter (fake module with the same API) ------------------------------
class _FakeTopography:
    def __init__(self, heights, sizes, unit):
        self._h, self.physical_sizes, self.unit = heights, sizes, unit
        self.nb_grid_pts = heights.shape

    def heights(self):
        return self._h


def fake_st(heights, sizes=(7.0, 10.0), unit="µm", channels=("Height", "Intensity")):
    """A stand-in for SurfaceTopography 1.27 (the API checked against the real package):
    open_topography(fn) as a context manager with .channels (each with .name, .nb_grid_pts,
    .physical_sizes, .unit) and .topography(channel_index=, physical_sizes=, unit=), which
    refuses a file without sizes unless physical_sizes is given."""
    mod = types.ModuleType("SurfaceTopography")
    mod.calls = []
    infos = [types.SimpleNamespace(name=n, nb_grid_pts=np.shape(heights), physical_sizes=sizes,
                                   unit=unit) for n in channels]

    class Reader:
        channels = infos

        def __init__(self, fn):
            if fn.endswith(".broken"):
                raise RuntimeError("CannotDetectFileFormat: tried 40 readers\nmore lines")
            self.fn = fn

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def topography(self, channel_index=None, physical_sizes=None, unit=None):
            mod.calls.append((self.fn, channel_index, physical_sizes, unit))
            if sizes is None and physical_sizes is None:
                raise ValueError("`physical_sizes` could not be extracted from file, you must "
                                 "provide it.")
            data = heights if not channel_index else heights + channel_index
            return _FakeTopography(data, physical_sizes or sizes, unit or infos[0].unit)

    mod.open_topography = Reader
    return mod


def instrument_file(tmp_path, name="scan.x3p"):
    p = tmp_path / name
    p.write_bytes(b"fake")
    return p


def test_surfacetopography_adapter_converts_units(tmp_path, monkeypatch):
    mod = fake_st(H)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", mod)
    p = instrument_file(tmp_path)
    t = read_topography(p)
    assert np.array_equal(t.heights, H * 1e-6)
    assert (t.dx, t.dy) == pytest.approx((1e-6, 2e-6), rel=1e-15)  # 7 µm / 7, 10 µm / 5
    assert mod.calls == [(str(p), 0, None, None)]      # the file's own sizes and unit
    for unit, factor in (("nm", 1e-9), ("mm", 1e-3), ("m", 1.0), ("Å", 1e-10)):
        monkeypatch.setitem(sys.modules, "SurfaceTopography", fake_st(H, unit=unit))
        t = read_topography(p)
        assert np.array_equal(t.heights, H * factor) and t.dx == pytest.approx(factor)
    # no unit in the file: height_unit applies to heights and sizes
    monkeypatch.setitem(sys.modules, "SurfaceTopography", fake_st(H, unit=None))
    t = read_topography(p, height_unit="nm")
    assert np.array_equal(t.heights, H * 1e-9) and t.dx == pytest.approx(1e-9)


def test_surfacetopography_channels_and_errors(tmp_path, monkeypatch):
    mod = fake_st(H)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", mod)
    p = instrument_file(tmp_path, "scan.sdf")
    np.testing.assert_allclose(read_topography(p, dataset="Intensity").heights, (H + 1) * 1e-6,
                               rtol=1e-14)
    np.testing.assert_allclose(read_topography(p, dataset=1).heights, (H + 1) * 1e-6,
                               rtol=1e-14)
    assert [c[1] for c in mod.calls] == [1, 1]
    assert "channel 5 not found (channels 0 to 1: Height, Intensity)" in msg_of(p, dataset=5)
    assert "channel 'Phase' not found (channels: Height, Intensity)" in msg_of(p, dataset="Phase")
    text = msg_of(instrument_file(tmp_path, "scan.broken"))
    assert "SurfaceTopography cannot read it (RuntimeError: CannotDetectFileFormat" in text
    monkeypatch.setitem(sys.modules, "SurfaceTopography", fake_st(H, unit="furlong"))
    assert "unit = 'furlong': unknown unit" in msg_of(p)
    # a format without sizes: spacing_um is passed on as the physical sizes (issue 20: it was
    # not, and the package refused the file)
    mod = fake_st(H, sizes=None)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", mod)
    assert "the file stores no physical size: give surface.spacing_um" in msg_of(p)
    t = read_topography(p, spacing=(UM, 2 * UM))
    assert (t.dx, t.dy) == pytest.approx((UM, 2 * UM), rel=1e-14)
    assert mod.calls[-1] == (str(p), 0, pytest.approx((7.0, 10.0)), None)   # in the file's µm
    assert "from argument (the file stores none)" in t.provenance
    mod = fake_st(H, sizes=None, unit=None)       # no unit either: height_unit names it
    monkeypatch.setitem(sys.modules, "SurfaceTopography", mod)
    t = read_topography(p, spacing=(UM, UM), height_unit="nm")
    assert mod.calls[-1] == (str(p), 0, pytest.approx((7000.0, 5000.0)), "nm")
    assert t.dx == pytest.approx(UM, rel=1e-14) and np.array_equal(t.heights, H * 1e-9)
    monkeypatch.setitem(sys.modules, "SurfaceTopography", fake_st(np.zeros(9), sizes=(1.0,)))
    assert "a line scan of (9,) points" in msg_of(p)


def test_surfacetopography_masked_points_follow_the_nan_policy(tmp_path, monkeypatch):
    masked = np.ma.masked_array(H, mask=np.zeros_like(H, bool))
    masked.mask[3, 3] = True
    monkeypatch.setitem(sys.modules, "SurfaceTopography", fake_st(masked))
    p = instrument_file(tmp_path)
    assert "1 of 35 points" in msg_of(p)
    t = read_topography(p, nan_policy="fill_mean")
    valid = ~masked.mask
    assert t.heights[3, 3] == pytest.approx(np.mean(H[valid]) * 1e-6, rel=1e-14)


# ---- maps that are not height maps (issue 20) ------------------------------------------------
@pytest.mark.parametrize("data,words", [
    ((H + 1j * H) * UM, "heights of dtype complex128: complex numbers, not heights"),
    (H > 0, "heights of dtype bool: true/false values, a mask rather than a height map"),
    (np.full((7, 5), 3e-7), "all 35 heights are 3e-07 m: a constant map has no roughness"),
    (H * 1e300, "heights span 1.32e+300 m (in m): no measured roughness map spans more than "
                "1 km; check height_unit"),
    (np.where(H > 0, 1e308, -1e308), "heights span inf m"),
])
def test_maps_that_are_not_height_maps_name_the_fault(tmp_path, data, words):
    p = tmp_path / "bad.npy"
    np.save(p, data)
    text = msg_of(p, spacing=(UM, UM))
    assert words in text and "smaller than the simulation window" not in text


@pytest.mark.slow
def test_the_scene_run_names_a_map_fault_in_one_line(tmp_path, capsys):
    """Through `micropit run`: the error names the file, the body's surface key and the
    fault (not the window size)."""
    from helpers import tiny_doc, write_scene

    from micropit_hpc.cli import main

    np.save(tmp_path / "c.npy", (H + 1j * H) * UM)
    doc = tiny_doc(slide_roll=(0.3,))
    doc["body1"]["surface"] = {"kind": "file", "file": "c.npy", "spacing_um": [40.0, 40.0],
                               "rescale": True}
    scene = write_scene(tmp_path / "s.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "o")]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if not ln.startswith("# ")]
    assert len(err) == 1 and err[0].startswith("micropit: error: ")
    assert "body1.surface" in err[0] and "complex numbers" in err[0]
