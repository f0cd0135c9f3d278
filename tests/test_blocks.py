"""Block arithmetic (issue 21 item 2): a run reaches exactly life.cycles_M, with a shorter last
block when block_M does not divide it, or the scene is refused."""

from __future__ import annotations

import csv

import h5py
import numpy as np
import pytest
from helpers import tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.errors import SceneError
from micropit_hpc.plan import MAX_BLOCKS, block_cycles, life_blocks
from micropit_hpc.scene import scene_from_dict


def scene_of(cycles_M, block_M):
    doc = tiny_doc()
    doc["life"].update(cycles_M=cycles_M, block_M=block_M)
    return scene_from_dict(doc, "tiny.toml")


@pytest.mark.parametrize("cycles_M, block_M, blocks, last_M", [
    (3.0, 1.0, 3, 1.0),
    (3.0, 1.2, 3, 0.6),      # the issue: ended at 2.4 M
    (3.4, 1.0, 4, 0.4),      # the issue: ended at 3.0 M
    (1.0, 0.3, 4, 0.1),
    (0.9, 0.3, 3, 0.3),      # 0.9/0.3 = 3.0000000000000004: round-off, not a 4th block
    (2.5, 2.5, 1, 2.5),
    (1e3, 0.1, 10_000, 0.1),
])
def test_the_blocks_add_up_to_the_life(cycles_M, block_M, blocks, last_M):
    scene = scene_of(cycles_M, block_M)
    assert life_blocks(scene) == blocks
    per = [block_cycles(scene, k) for k in range(1, blocks + 1)]
    assert all(c == scene.life.block for c in per[:-1])
    assert per[-1] == pytest.approx(last_M * 1e6, rel=1e-9)
    assert sum(per) == pytest.approx(cycles_M * 1e6, rel=1e-12)
    assert min(per) > 0


def test_a_life_of_too_many_blocks_is_refused_in_one_line():
    with pytest.raises(SceneError) as e:
        life_blocks(scene_of(1e6, 1e-6))
    text = str(e.value)
    assert "tiny.toml: life.block_M = 1e-06" in text and str(MAX_BLOCKS) in text
    assert "\n" not in text


def test_micropit_scene_refuses_it_too(tmp_path, capsys):
    doc = tiny_doc()
    doc["life"].update(cycles_M=1e6, block_M=1e-6)
    path = write_scene(tmp_path / "many.toml", doc)
    assert main(["scene", str(path)]) == 2
    assert "life.block_M = 1e-06" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_run_with_a_non_dividing_block_ends_at_exactly_the_life(tmp_path, capsys):
    doc = tiny_doc(slide_roll=(0.3,))
    doc["life"].update(cycles_M=1.5, block_M=1.0)
    path = write_scene(tmp_path / "t.toml", doc)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "2 blocks of 1 M cycles, the last of 0.5 M to 1.5 M" in err
    with open(out / "summary.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert sorted({float(r["cycles"]) for r in rows}) == [1e6, 1.5e6]
    with h5py.File(out / "results.h5", "r") as f:
        cycles = f["history/item_00000/cycles"][()]
        assert np.array_equal(cycles, [1e6, 1.5e6])
        assert f.attrs["blocks_done"] == 2
