"""benchmarks/bench_wear_convergence.py continues a killed run from its state file to the same
numbers, bit for bit, as a run straight through, and refuses a state written by other code."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import load_benchmark

from micropit_hpc.scene import load_scene

ROOT = Path(__file__).resolve().parents[1]


def _bench():
    return load_benchmark("bench_wear_convergence")


def test_a_run_continued_from_its_state_gives_the_straight_run_bit_for_bit(tmp_path):
    bench = _bench()
    col = bench.COLUMNS.index
    base = load_scene(ROOT / "scenes" / "quick.toml")
    ref = bench.reference_surfaces(base, 32)
    case = (base, 2, 5e-11, 32, 0.01)           # position 2, k_lub, n, ΔN [M]

    straight = []
    bench._run(*case, 0.02, ref, straight.append)
    assert [r[col("cycles_M")] for r in straight] == [0.01, 0.02]
    assert {r[col("process_length_um")] for r in straight} == {10.0}     # the scene's ℓ

    state = tmp_path / "state.npz"
    first, rest = [], []
    bench._run(*case, 0.01, ref, first.append, state=state, tree="tree-a")
    assert state.exists() and first[0][:-1] == straight[0][:-1]
    bench._run(*case, 0.02, ref, rest.append, state=state, tree="tree-a")
    # one block more, from the state: every column but the wall clock the straight run's,
    # the sub-blocks and contact-only cycles counted from the start
    assert len(rest) == 1 and rest[0][:-1] == straight[1][:-1]
    subs, wear = col("sub_blocks"), col("wear_um")
    assert rest[0][subs] > first[0][subs] and rest[0][-1] >= first[0][-1]
    assert rest[0][wear] > first[0][wear] > 0.0            # the item wears on

    # a state written by other code is refused, naming the file; it is left as it was
    before = state.read_bytes()
    with pytest.raises(SystemExit, match="state.npz.*tree-a.*tree-b"):
        bench._run(*case, 0.03, ref, rest.append, state=state, tree="tree-b")
    with pytest.raises(SystemExit, match="uncommitted"):
        bench._run(*case, 0.03, ref, rest.append, state=state, tree="")
    assert state.read_bytes() == before and len(rest) == 1


def test_the_csv_tells_which_runs_stop_short(tmp_path):
    bench = _bench()
    path = tmp_path / "rows.csv"
    path.write_text(",".join(bench.COLUMNS) + "\n"
                    "quick,10,2,5e-11,32,0.01,0.01,1,1,1,0.1,0.1,1,1,1,1,1,1\n"
                    "quick,10,2,5e-11,32,0.01,0.02,1,1,1,0.1,0.1,1,1,1,1,1,1\n"
                    "quick,0,2,5e-11,32,0.01,0.03,1,1,1,0.1,0.1,1,1,1,1,1,1\n"
                    "quick,10,2,1e-11,32,0.01,0.01,1,1,1,0.1,0.1,1,1,1,1,1,1\n")
    # a pointwise run (ℓ = 0) is another run than the same case at 10 µm
    assert bench._done(path) == {(10.0, "2", 5e-11, 32, 0.01): 0.02,
                                 (0.0, "2", 5e-11, 32, 0.01): 0.03,
                                 (10.0, "2", 1e-11, 32, 0.01): 0.01}
    assert bench._done(tmp_path / "none.csv") == {}
    # a CSV of the earlier columns (no ℓ: pointwise rows) is refused, naming the file
    old = tmp_path / "old.csv"
    old.write_text(",".join(c for c in bench.COLUMNS if c != "process_length_um") + "\n")
    with pytest.raises(SystemExit, match="old.csv.*process_length_um.*new --csv"):
        bench._done(old)
