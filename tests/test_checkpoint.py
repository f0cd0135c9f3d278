"""Checkpoint files on one rank: round trip, pruning, and every kind of unusable file skipped
(docs/hpc.md §3). The parallel contract is in test_checkpoint_mpi.py."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from micropit_hpc.errors import MicropitError
from micropit_hpc.io.checkpoint import (
    FORMAT_VERSION,
    CheckpointError,
    FieldSpec,
    Piece,
    block_of,
    find_latest,
    read_checkpoint,
    verify_checkpoint,
    write_checkpoint,
)
from micropit_hpc.parallel import SerialComm

ROOT = Path(__file__).resolve().parents[1]
FIELDS = [FieldSpec("damage", (5, 4, 3), "f8"), FieldSpec("state/cycles", (), "i8"),
          FieldSpec("state/rough", (6,), "f4")]
N_ITEMS = 4


def damage(item):
    return np.arange(60.0).reshape(5, 4, 3) + 100.0 * item


def all_pieces():
    out = []
    for item in range(N_ITEMS):
        out.append(Piece(item, "damage", damage(item)))
        out.append(Piece(item, "state/cycles", np.int64(1000 * item)))
        out.append(Piece(item, "state/rough", np.linspace(0, 1, 6, dtype=np.float32) + item))
    return out


def write(tmp, block, pieces=None, keep=3, **attrs):
    return write_checkpoint(tmp, SerialComm(), block, N_ITEMS, FIELDS,
                            all_pieces() if pieces is None else pieces,
                            {"cycles_done": 10 * block, **attrs}, keep=keep)


def names(directory):
    return sorted(p.name for p in Path(directory).iterdir())


def test_round_trip_of_fields_regions_and_attributes(tmp_path):
    rng = np.random.default_rng(2018)
    rng.standard_normal(5)
    state = rng.bit_generator.state  # 128-bit integers: must come back exactly
    scene = {"name": "gear_z23", "load": {"torque_Nm": 250.0}, "positions": [1, 2, 3]}
    path = write(tmp_path, 7, scene=scene, rng=state, label="run α", wear=2.5e-9,
                 heights=np.array([1.0, 2.0]), flag=True)
    assert path == tmp_path / "ckpt_000007.h5" and block_of(path) == 7
    assert names(tmp_path) == ["LATEST", "ckpt_000007.h5"]
    assert (tmp_path / "LATEST").read_text().strip() == "ckpt_000007.h5"
    requests = [(2, "damage", None), (3, "state/cycles", None), (1, "state/rough", None),
                (0, "damage", (slice(1, 4), slice(None), slice(0, 3, 2)))]
    attrs, data = read_checkpoint(path, SerialComm(), requests)
    assert np.array_equal(data[(2, "damage")], damage(2))
    assert data[(3, "state/cycles")] == 3000 and data[(3, "state/cycles")].shape == ()
    assert data[(1, "state/rough")].dtype == np.float32
    assert np.array_equal(data[(1, "state/rough")], np.linspace(0, 1, 6, dtype=np.float32) + 1)
    assert np.array_equal(data[(0, "damage")], damage(0)[1:4, :, 0:3:2])
    assert (attrs["block"], attrs["cycles_done"], attrs["ranks"], attrs["complete"]) == (7, 70,
                                                                                         1, 1)
    assert attrs["format_version"] == FORMAT_VERSION and attrs["utc"].endswith("+00:00")
    assert attrs["label"] == "run α" and attrs["wear"] == 2.5e-9 and attrs["flag"] is True
    assert np.array_equal(attrs["heights"], [1.0, 2.0])
    assert isinstance(attrs["scene"], str) and json.loads(attrs["scene"]) == scene
    restored = np.random.default_rng()
    restored.bit_generator.state = json.loads(attrs["rng"])
    assert np.array_equal(restored.standard_normal(4), rng.standard_normal(4))
    assert verify_checkpoint(path)["block"] == 7


def test_an_item_written_in_disjoint_pieces(tmp_path):
    d = damage(1)
    pieces = [Piece(1, "damage", d[:2], (slice(0, 2),)),
              Piece(1, "damage", d[2:, :, :1], (slice(2, 5), slice(None), slice(0, 1))),
              Piece(1, "damage", d[2:, :, 1:], (slice(2, None), slice(None), slice(1, 3))),
              Piece(1, "damage", np.zeros((0, 4, 3)), (slice(5, 5),)),  # an empty slab
              Piece(3, "damage", damage(3)[0::2], (slice(0, None, 2),)),  # interleaved rows
              Piece(3, "damage", damage(3)[1::2], (slice(1, None, 2),))]
    path = write(tmp_path, 1, pieces=pieces)
    _, data = read_checkpoint(path, SerialComm(), [(1, "damage", None), (0, "damage", None),
                                                   (3, "damage", None)])
    assert np.array_equal(data[(1, "damage")], d)
    assert np.array_equal(data[(3, "damage")], damage(3))
    assert not data[(0, "damage")].any()  # never written: the fill value


@pytest.mark.parametrize("piece,text", [
    (Piece(0, "nope", np.zeros(3)), "unknown field 'nope'"),
    (Piece(4, "state/cycles", np.int64(1)), "item 4 outside"),
    (Piece(0, "damage", np.zeros((5, 4))), "data of shape"),
    (Piece(0, "damage", np.zeros((2, 4, 3)), (slice(0, 3),)), "region of shape"),
    (Piece(0, "damage", np.zeros((5, 4, 3)), (slice(None, None, -1),)), "step must be positive"),
    (Piece(0, "state/cycles", np.float64(1.5)), "cannot be stored as int64"),
])
def test_bad_pieces_are_refused_before_anything_is_written(tmp_path, piece, text):
    with pytest.raises(MicropitError, match=text):
        write(tmp_path, 1, pieces=[piece])
    assert not tmp_path.exists() or names(tmp_path) == []


@pytest.mark.parametrize("attrs,text", [({"utc": "now"}, "set by write_checkpoint"),
                                        ({"bad": object()}, "unsupported type"),
                                        ({"huge": 2**70}, "does not fit in 64 bits")])
def test_bad_attributes_are_refused(tmp_path, attrs, text):
    with pytest.raises(MicropitError, match=text):
        write(tmp_path, 1, **attrs)
    assert names(tmp_path) == []


def test_keep_prunes_old_checkpoints_and_stale_temporaries(tmp_path):
    write(tmp_path, 1)
    (tmp_path / "ckpt_000002.h5.tmp").write_bytes(b"left by a crash")
    for block in (3, 4, 5):
        write(tmp_path, block, keep=2)
    assert names(tmp_path) == ["LATEST", "ckpt_000004.h5", "ckpt_000005.h5"]
    write(tmp_path, 6, keep=1)
    assert names(tmp_path) == ["LATEST", "ckpt_000006.h5"]
    assert find_latest(tmp_path) == tmp_path / "ckpt_000006.h5"


def test_a_leftover_tmp_is_ignored_then_overwritten(tmp_path):
    write(tmp_path, 1)
    (tmp_path / "ckpt_000002.h5.tmp").write_bytes(b"\x89HDF torn")
    (tmp_path / "ckpt_000009.h5.tmp").write_bytes(b"")
    assert find_latest(tmp_path) == tmp_path / "ckpt_000001.h5"
    path = write(tmp_path, 2)
    assert not (tmp_path / "ckpt_000002.h5.tmp").exists()
    assert find_latest(tmp_path) == path
    _, data = read_checkpoint(path, SerialComm(), [(3, "damage", None)])
    assert np.array_equal(data[(3, "damage")], damage(3))


def test_a_file_without_the_complete_flag_is_skipped(tmp_path):
    good = write(tmp_path, 1)
    with h5py.File(tmp_path / "ckpt_000002.h5", "w") as f:  # everything but the flag
        f.create_dataset("damage", data=np.zeros((N_ITEMS, 5, 4, 3)))
        f.attrs["format_version"] = 1
    skipped = []
    assert find_latest(tmp_path, on_skip=skipped.append) == good
    assert len(skipped) == 1 and "ckpt_000002.h5: incomplete checkpoint" in str(skipped[0])
    with pytest.raises(CheckpointError, match="ckpt_000002.h5: incomplete"):
        read_checkpoint(tmp_path / "ckpt_000002.h5", SerialComm(), [])


@pytest.mark.parametrize("keep_fraction", [0.5, 0.9, 0.999])
def test_a_truncated_file_is_skipped(tmp_path, keep_fraction):
    good = write(tmp_path, 1)
    torn = write(tmp_path, 2)
    os.truncate(torn, int(torn.stat().st_size * keep_fraction))
    skipped = []
    assert find_latest(tmp_path, on_skip=skipped.append) == good
    assert [Path(str(e).split(":")[0]).name for e in skipped] == ["ckpt_000002.h5"]
    with pytest.raises(CheckpointError, match="ckpt_000002.h5"):
        verify_checkpoint(torn)


def test_a_newer_format_is_skipped(tmp_path):
    good = write(tmp_path, 1)
    newer = write(tmp_path, 2)
    with h5py.File(newer, "r+") as f:
        f.attrs["format_version"] = 99
    with pytest.raises(CheckpointError, match="format 99"):
        verify_checkpoint(newer)
    assert find_latest(tmp_path) == good


def test_find_latest_without_checkpoints(tmp_path):
    assert find_latest(tmp_path) is None
    assert find_latest(tmp_path / "missing") is None
    (tmp_path / "ckpt_000001.h5").write_bytes(b"not HDF5")
    (tmp_path / "notes.h5").write_bytes(b"")
    assert find_latest(tmp_path) is None


def test_checkpoint_error_names_the_file(tmp_path):
    junk = tmp_path / "ckpt_000003.h5"
    junk.write_bytes(b"garbage" * 100)
    with pytest.raises(CheckpointError, match=r"ckpt_000003\.h5: unreadable checkpoint"):
        verify_checkpoint(junk)
    with pytest.raises(CheckpointError, match=r"ckpt_000003\.h5: cannot be opened"):
        read_checkpoint(junk, SerialComm(), [(0, "damage", None)])
    with pytest.raises(CheckpointError, match=r"ckpt_000004\.h5: no such checkpoint"):
        read_checkpoint(tmp_path / "ckpt_000004.h5", SerialComm(), [])
    good = write(tmp_path, 5)
    with pytest.raises(CheckpointError, match=r"ckpt_000005\.h5: no field 'pressure'"):
        read_checkpoint(good, SerialComm(), [(0, "pressure", None)])
    with pytest.raises(CheckpointError, match=r"ckpt_000005\.h5: field 'damage' has items"):
        read_checkpoint(good, SerialComm(), [(9, "damage", None)])


CRASH_CHILD = """
import os, signal, sys
import numpy as np
from micropit_hpc.io import checkpoint as ck
from micropit_hpc.parallel import SerialComm

directory, stage = sys.argv[1], sys.argv[2]
fields = [ck.FieldSpec("damage", (3, 2), "f8")]
def pieces(block):
    return [ck.Piece(i, "damage", np.full((3, 2), 10.0 * block + i)) for i in range(4)]
ck.write_checkpoint(directory, SerialComm(), 1, 4, fields, pieces(1), {"cycles_done": 1})

def die(name, path):
    if name == stage:
        os.kill(os.getpid(), signal.SIGKILL)
ck._at_stage = die
ck.write_checkpoint(directory, SerialComm(), 2, 4, fields, pieces(2), {"cycles_done": 2})
print("not killed")
"""


@pytest.mark.timeout(60)
@pytest.mark.parametrize("stage,survivor", [("created", 1), ("data", 1), ("closed", 1),
                                            ("renamed", 2)])
def test_a_writer_killed_mid_checkpoint_leaves_a_usable_one(tmp_path, stage, survivor):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_"))}
    env["PYTHONPATH"] = str(ROOT)
    run = subprocess.run([sys.executable, "-c", textwrap.dedent(CRASH_CHILD), str(tmp_path),
                          stage], env=env, capture_output=True, text=True, timeout=50)
    assert run.returncode == -9, run.stderr
    # Until LATEST is rewritten it names block 1; a renamed block 2 is complete already.
    assert (tmp_path / "LATEST").read_text().strip() == "ckpt_000001.h5"
    assert (tmp_path / "ckpt_000002.h5.tmp").exists() == (survivor == 1)
    latest = find_latest(tmp_path)
    assert latest == tmp_path / f"ckpt_00000{survivor}.h5"
    attrs, data = read_checkpoint(latest, SerialComm(), [(3, "damage", None)])
    assert attrs["cycles_done"] == survivor
    assert np.array_equal(data[(3, "damage")], np.full((3, 2), 10.0 * survivor + 3))
    # The next run overwrites the leftover and goes on.
    fields = [FieldSpec("damage", (3, 2), "f8")]
    write_checkpoint(tmp_path, SerialComm(), 2, 4, fields,
                     [Piece(0, "damage", np.ones((3, 2)))], {"cycles_done": 2})
    assert names(tmp_path) == ["LATEST", "ckpt_000001.h5", "ckpt_000002.h5"]
    assert find_latest(tmp_path) == tmp_path / "ckpt_000002.h5"
