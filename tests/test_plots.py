"""The plot scripts' helpers (issue 20): items named by position, robust colour scales, the
path points A–E read back from results.h5 (through micropit_hpc.io.results.load_results)."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import h5py
import numpy as np
import pytest

from micropit_hpc.io.results import load_results

ROOT = Path(__file__).resolve().parents[1]


def _load(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "postprocess" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


plot_life = _load("plot_life")
plot_flank = _load("plot_flank")


def test_robust_limits_ignore_a_few_outliers():
    rng = np.random.default_rng(1)
    heights = rng.normal(0.0, 1.0, (64, 64))
    heights[:2, :2] = -500.0                     # four deep pits in 4096 points
    lo, hi = plot_life.robust_limits([heights])
    assert -3.0 < lo < -2.0 and 2.0 < hi < 3.0
    assert plot_life.robust_limits([np.zeros((4, 4))])[1] > 0.0      # a flat map still works


def test_shown_items_spread_over_the_study():
    assert plot_life.shown_items(np.arange(4), 6) == [0, 1, 2, 3]
    assert plot_life.shown_items(np.arange(33), 4) == [0, 11, 21, 32]


def _items_file(path, roll, k_lub):
    """The smallest results.h5 load_results accepts: items, one block of history, the grid, the
    path points A–E."""
    with h5py.File(path, "w") as f:
        f.attrs["complete"] = 1
        n = len(roll)
        for i in range(n):
            f[f"history/item_{i:05d}/cycles"] = np.array([1e6])
            f[f"history/item_{i:05d}/Ap"] = np.array([[1.0, 2.0]])
        for k, v in (("x", np.arange(4.0)), ("y", np.arange(3.0)), ("z", np.arange(2.0)),
                     ("dx", 1.0), ("dy", 1.0)):
            f[f"grid/{k}"] = v
        f["items/id"] = np.arange(n)
        f["items/position"] = np.arange(1, n + 1)
        f["items/S"] = np.linspace(-0.5, 0.5, n)
        f["items/k_lub"] = np.array(k_lub)
        f["items/roughness_scale"] = np.ones(n)
        f["items/patch"] = np.zeros(n, dtype=int)
        f["items/roll_angle"] = np.array(roll)
        g = f.create_group("path")
        for k, v in zip("ABCDE", (0.3, 0.4, 0.5, 0.6, 0.7), strict=True):
            g.attrs[f"{k}_roll_angle"] = v
    return path


def test_items_are_labelled_by_position_and_what_varies(tmp_path):
    path = _items_file(tmp_path / "r.h5", [math.radians(20.0), math.radians(27.77)],
                       [0.0, 1e-11])
    labels = plot_life.item_labels(load_results(path).items)
    assert labels == {0: "pos 1 (φ1 20.0°, S -0.50), k 0e+00 s",
                      1: "pos 2 (φ1 27.8°, S +0.50), k 1e-11 s"}
    path = _items_file(tmp_path / "d.h5", [math.nan], [0.0])      # a disc rig, one k_lub
    assert plot_life.item_labels(load_results(path).items) == {0: "pos 1 (S -0.50)"}


def test_the_flank_plot_reads_the_path_points(tmp_path):
    (tmp_path / "run").mkdir()
    _items_file(tmp_path / "run" / "results.h5", [0.4], [0.0])
    data = plot_flank.path_data(tmp_path / "run")
    assert data["points"] == pytest.approx({k: math.degrees(v) for k, v in
                                            zip("ABCDE", (0.3, 0.4, 0.5, 0.6, 0.7),
                                                strict=True)})
    assert math.isnan(data["lambda_GFP"]) and data["roll_deg"].size == 0
