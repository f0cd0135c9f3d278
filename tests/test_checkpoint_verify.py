"""Verified checkpoints (issue 21 item 3): a restart reads every element of a checkpoint
(Fletcher-32 per chunk, HDF5's metadata checksums), checks that every dataset and attribute of
the run is there and finite, and falls back to the previous good checkpoint with a message;
``LATEST`` leads the way (a newer leftover of another run is ignored); a measured-surface file
that changed since the checkpoint is refused unless --force."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest
from helpers import results_differ, tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.io.checkpoint import CheckpointError, find_latest, verify_checkpoint


def doc_of():
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-10,))
    doc["life"]["cycles_M"] = 3.0
    return doc


@pytest.fixture(scope="module")
def straight(tmp_path_factory):
    d = tmp_path_factory.mktemp("verify")
    scene = write_scene(d / "tiny.toml", doc_of())
    assert main(["run", str(scene), "--out", str(d / "out")]) == 0
    names = sorted(p.name for p in (d / "out" / "checkpoints").iterdir())
    assert names == ["LATEST", "ckpt_000001.h5", "ckpt_000002.h5", "ckpt_000003.h5"]
    return scene, d / "out"


def copy_of(ref, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    for name in ("summary.csv", "results.h5"):
        (out / name).unlink()
    return out


def flip_bytes(path, dataset, n=64):
    """Flip ``n`` bytes in the middle of ``dataset``'s first chunk, in place on disk."""
    with h5py.File(path, "r") as f:
        info = f[dataset].id.get_chunk_info(0)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        data = bytearray(fh.read(n))
        fh.seek(info.byte_offset + info.size // 2)
        fh.write(bytes(b ^ 0xFF for b in data))


def restart(scene, out, capsys):
    rc = main(["run", str(scene), "--out", str(out), "--restart"])
    return rc, capsys.readouterr().err


@pytest.mark.slow
def test_every_dataset_carries_a_checksum(straight):
    _, ref = straight
    with h5py.File(ref / "checkpoints" / "ckpt_000003.h5", "r") as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert len(names) == 12
        assert all(f[n].fletcher32 for n in names)
        assert len(f.attrs["run_id"]) == 32


@pytest.mark.slow
def test_flipped_bytes_inside_the_damage_fall_back_to_the_previous_checkpoint(
        straight, tmp_path, capsys):
    scene, ref = straight
    out = copy_of(ref, tmp_path)
    bad = out / "checkpoints" / "ckpt_000003.h5"
    flip_bytes(bad, "body1/damage")
    with pytest.raises(CheckpointError, match="unreadable checkpoint"):
        verify_checkpoint(bad)
    rc, err = restart(scene, out, capsys)
    assert rc == 0, err
    assert f"skipped {bad}" in err and "block 2 of 3" in err
    assert results_differ(ref, out) == []


@pytest.mark.slow
@pytest.mark.parametrize("dataset", ["body1/damage", "state", "records", "body2/heights"])
def test_a_missing_dataset_falls_back(straight, tmp_path, capsys, dataset):
    scene, ref = straight
    out = copy_of(ref, tmp_path)
    bad = out / "checkpoints" / "ckpt_000003.h5"
    with h5py.File(bad, "r+") as f:
        del f[dataset]
    rc, err = restart(scene, out, capsys)
    assert rc == 0, err
    assert f"dataset '{dataset}' is missing" in err and "block 2 of 3" in err
    assert "Traceback" not in err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_nan_heights_and_a_missing_attribute_fall_back_twice(straight, tmp_path, capsys):
    scene, ref = straight
    out = copy_of(ref, tmp_path)
    with h5py.File(out / "checkpoints" / "ckpt_000003.h5", "r+") as f:
        h = f["body1/heights"][0]
        h[3, 4] = np.nan
        f["body1/heights"][0] = h    # rewritten through HDF5: the checksum is valid
    with h5py.File(out / "checkpoints" / "ckpt_000002.h5", "r+") as f:
        del f.attrs["items"]
    rc, err = restart(scene, out, capsys)
    assert rc == 0, err
    assert "body1/heights holds 1 non-finite values" in err
    assert "attribute 'items' is missing" in err
    assert "block 1 of 3" in err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_a_newer_leftover_of_another_run_is_not_used(straight, tmp_path, capsys):
    """LATEST names block 2; a block-3 file of another run (other run_id) is a leftover."""
    scene, ref = straight
    out = copy_of(ref, tmp_path)
    ck = out / "checkpoints"
    with h5py.File(ck / "ckpt_000003.h5", "r+") as f:
        f.attrs["run_id"] = "0" * 32
    (ck / "LATEST").write_text("ckpt_000002.h5\n")
    rc, err = restart(scene, out, capsys)
    assert rc == 0, err
    assert "not of the same run" in err and "block 2 of 3" in err
    assert results_differ(ref, out) == []


@pytest.mark.slow
def test_a_newer_checkpoint_of_the_same_run_is_used(straight, tmp_path):
    """A crash between the rename of block 3 and the update of LATEST loses nothing."""
    _, ref = straight
    out = copy_of(ref, tmp_path)
    (out / "checkpoints" / "LATEST").write_text("ckpt_000002.h5\n")
    assert find_latest(out / "checkpoints") == out / "checkpoints" / "ckpt_000003.h5"


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_a_replaced_measured_surface_is_refused_unless_forced(tmp_path, capsys):
    doc = doc_of()
    rng = np.random.default_rng(1)
    np.save(tmp_path / "flank.npy", rng.normal(0, 0.16e-6, (32, 32)))
    doc["body1"]["surface"] = {"kind": "file", "file": "flank.npy",
                               "spacing_um": [6.25, 6.25], "rescale": True}
    scene = write_scene(tmp_path / "measured.toml", doc)
    out = tmp_path / "out"
    stop = tmp_path / "STOP"
    stop.touch()
    assert main(["run", str(scene), "--out", str(out), "--stop-file", str(stop)]) == 85
    stop.unlink()
    np.save(tmp_path / "flank.npy", rng.normal(0, 0.16e-6, (32, 32)))  # same path, new data
    capsys.readouterr()
    rc, err = restart(scene, out, capsys)
    assert rc == 2
    assert "flank.npy changed since the checkpoint was written" in err and "--force" in err
    assert main(["run", str(scene), "--out", str(out), "--restart", "--force"]) == 0
