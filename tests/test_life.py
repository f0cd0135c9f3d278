"""The life loop at one contact point: Miner, wear, pits, moving damage columns, adaptive
blocks (docs/model.md §4.4–§5)."""

import dataclasses
import itertools
import math

import numpy as np
import pytest
from helpers import evaluate, fake_result, tiny_doc

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import BodyCycle, CycleResult, PositionCycle, micro_cycles, rainflow_steps
from micropit_hpc.life import (
    BodyState,
    LifeState,
    _new_pits,
    apply_cycles,
    initial_state,
    run_block,
    shape_change,
    smallest_sub_block,
    sub_block_cycles,
)
from micropit_hpc.parallel import SerialComm
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.pits import detach, layer_bottoms, shift_columns
from micropit_hpc.plan import WorkItem
from micropit_hpc.scene import LifeSpec, scene_from_dict
from micropit_hpc.spectral import Grid
from micropit_hpc.study import ItemRun
from micropit_hpc.wear import WearRate, archard_wear, to_material_frame


@pytest.fixture(scope="module")
def tiny():
    scene = scene_from_dict(tiny_doc(), "tiny.toml")
    return scene, contact_study(scene)


# ---- pits and damage columns ------------------------------------------------------------------
def test_layer_bottoms():
    np.testing.assert_allclose(layer_bottoms(np.array([0.0, 1.0, 4.0, 9.0])),
                               [0.5, 2.5, 6.5, 11.5])


def test_detach_removes_down_to_the_deepest_failed_layer():
    z = np.array([0.0, 1.0, 4.0, 9.0])
    D = np.zeros((4, 2, 1))
    D[:, 0, 0] = [0.5, 1.2, 0.3, 0.1]
    D[:, 1, 0] = [0.2, 0.2, 0.2, 0.2]
    out, depth, new = detach(D, z)
    assert new.ravel().tolist() == [True, False]
    assert depth.ravel().tolist() == [2.5, 0.0]
    # removed layers' damage discarded; material from 2.5 below comes up
    # (the deepest layer now reads z = 11.5, its own bottom: zero-damage refill)
    np.testing.assert_allclose(out[:, 0, 0], [0.15, 0.25, 0.2, 0.0])
    assert np.array_equal(out[:, 1, 0], D[:, 1, 0])
    assert (out < 1).all()


def test_shift_columns_moves_damage_up_and_is_exact_for_no_shift():
    z = np.array([0.0, 1.0, 4.0, 9.0])
    rng = np.random.default_rng(0)
    D = rng.uniform(size=(4, 3, 2))
    assert np.array_equal(shift_columns(D, z, np.zeros((3, 2))), D)
    s = shift_columns(D, z, np.full((3, 2), 1.0))
    np.testing.assert_allclose(s[0], D[1])                       # z=0 now holds z=1
    np.testing.assert_allclose(s[1], D[1] + (D[2] - D[1]) / 3)   # z=1 holds z=2
    # below z_max = 9 the damage fades to zero at the deepest layer's bottom, 11.5
    np.testing.assert_allclose(s[3], D[3] * (11.5 - 10.0) / 2.5)
    assert np.array_equal(shift_columns(D, z, np.full((3, 2), 2.5))[3], np.zeros((3, 2)))
    assert (s >= 0).all()


def test_failed_material_never_re_enters_and_one_pit_stops_at_z_max():
    """A column whose deepest layer has failed: the pit removes it down to z_max (not the
    layer's bottom), the material that comes up is fresh; repeated wear shifts bring no failed
    material up (the earlier refill with the deepest layer's damage made it re-enter and pits
    dig far below the layers)."""
    z = np.array([0.0, 1.0, 4.0, 9.0])
    D = np.zeros((4, 1, 1))
    D[:, 0, 0] = [0.2, 0.4, 0.9, 1.5]                  # the deepest layer has failed
    out, depth, new = detach(D, z)
    assert new.all() and depth.ravel().tolist() == [9.0]
    assert np.array_equal(out, np.zeros_like(D))
    D[:, 0, 0] = [0.2, 0.4, 0.9, 0.99]
    for _ in range(20):                                  # wear shifts, 0.5 each
        D = shift_columns(D, z, np.full((1, 1), 0.5))
        assert detach(D, z)[2].sum() == 0
    assert D.max() < 0.99


# ---- wear ----------------------------------------------------------------------------------
def test_material_frame_shift_conserves_and_stays_non_negative():
    rng = np.random.default_rng(1)
    f = np.where(rng.uniform(size=(32, 8)) > 0.7, rng.uniform(size=(32, 8)), 0.0)
    for shift in (0.0, 0.3, -2.7, 13.25):
        g = to_material_frame(f, shift * 1e-6, 1e-6)
        assert g.sum() == pytest.approx(f.sum(), rel=1e-13)
        assert (g >= 0).all()
    assert np.array_equal(to_material_frame(f, 3e-6, 1e-6), np.roll(f, -3, axis=0))


def test_material_frame_shift_is_the_rolled_interpolation_bit_for_bit():
    """The sliced interpolation gives the bits of (1 − f) roll(F, −q) + f roll(F, −q − 1),
    in the field's precision, for shifts of either sign, beyond the window and between
    cells, on 2-D and layered fields."""
    rng = np.random.default_rng(7)
    for shape, dtype in (((24, 10), np.float64), ((24, 10), np.float32),
                         ((5, 3, 4), np.float64), ((1, 6), np.float64)):
        f = rng.normal(size=shape).astype(dtype)
        for shift in (0.3, -0.3, 1.0 - 1e-12, 23.999, -47.5, 100.125, 7.75):
            cells = (shift * 1e-6) / 1e-6
            q = math.floor(cells)
            w = cells - q
            rolled = np.roll(f, -q, axis=0)
            want = (1.0 - w) * rolled + w * np.roll(rolled, -1, axis=0)
            got = to_material_frame(f, shift * 1e-6, 1e-6)
            assert got.dtype == want.dtype
            assert np.array_equal(got, want), (shape, dtype, shift)


def test_archard_rate_formula():
    """Uniform p, half the steps solid: Δh = ½ |u_s|/H · mean(k p), k = f_w k_lub or k_lub."""
    p = np.full((8, 4), 2e9)
    solid = [np.ones((8, 4), bool), np.zeros((8, 4), bool)]
    w = archard_wear([p, p], solid, [0.0, 1e-6], 1e-6, u_s=0.33, hardness=7e9,
                     counter_hardness=8e9, k_lub=1e-11, f_w=10.0, cell_compliance=3e-17)
    expect = 0.5 * 0.33 / 7e9 * (10 * 1e-11 * 2e9 + 1e-11 * 2e9) / 2
    np.testing.assert_allclose(w.rate, expect, rtol=1e-14)
    np.testing.assert_allclose(w.fluid, 0.5 * 0.33 / 7e9 * 1e-11 * 2e9 / 2, rtol=1e-14)
    # ρ = ½|u_s| f_w k_lub (1/H_1 + 1/H_2) f_s / K₀ with f_s = ½
    np.testing.assert_allclose(w.relax, 0.5 * 0.33 * 10 * 1e-11 * (1 / 7e9 + 1 / 8e9) * 0.5
                               / 3e-17, rtol=1e-14)
    still = archard_wear([p], [solid[0]], [0.0], 1e-6, 0.0, 7e9, 7e9, 1e-11, 10.0, 3e-17)
    assert not still.rate.any() and not still.depth(1e6).any()
    # the steps weighted by their share of the transit (cosine steps, docs/model.md §4): ¼ of
    # the time solid, ¾ fluid; equal weights are the unweighted rates
    args = ([p, p], solid, [0.0, 1e-6], 1e-6, 0.33, 7e9, 8e9, 1e-11, 10.0, 3e-17)
    q = archard_wear(*args, weights=[0.25, 0.75])
    # rtol 1e-14 (about 45 ulp) bounds these: products of under ten factors (an ulp each) and
    # sums of two steps of a uniform field, whose shift to the material frame is exact to a
    # few ulp whatever the summation order
    np.testing.assert_allclose(q.solid, 0.5 * 0.33 / 7e9 * 10 * 1e-11 * 2e9 * 0.25, rtol=1e-14)
    np.testing.assert_allclose(q.fluid, 0.5 * 0.33 / 7e9 * 1e-11 * 2e9 * 0.75, rtol=1e-14)
    np.testing.assert_allclose(q.relax, w.relax * 0.5, rtol=1e-14)
    even = archard_wear(*args, weights=[0.5, 0.5])
    for a, b in ((even.solid, w.solid), (even.fluid, w.fluid), (even.relax, w.relax)):
        np.testing.assert_allclose(a, b, rtol=1e-14)


# ---- Miner, wear and pits through apply_cycles -------------------------------------------------
def test_miner_additivity(tiny):
    """Two blocks of ΔN equal one block of 2ΔN when nothing changes (no pits, no wear)."""
    scene, study = tiny
    cyc = PositionCycle(study, 2)
    res = evaluate(cyc, initial_state(cyc))
    scaled = CycleResult(bodies=tuple(BodyCycle(damage_rate=b.damage_rate / (10 * max(
        b.damage_rate.max(), 1e-300)), wear=b.wear, tau_rough=b.tau_rough,
        tau_smooth=b.tau_smooth, n_micro=b.n_micro, lam_c=b.lam_c) for b in res.bodies),
        phi=res.phi, solid_fraction=res.solid_fraction, steps=res.steps, wall_s=0.0)
    a, b = initial_state(cyc), initial_state(cyc)
    how = "relaxed"                 # apply_cycles integrates a rate (implicit re-solves it)
    apply_cycles(a, scaled, 2.0, cyc.z, cyc.slab, how)
    apply_cycles(b, scaled, 1.0, cyc.z, cyc.slab, how)
    apply_cycles(b, scaled, 1.0, cyc.z, cyc.slab, how)
    for x, y in zip(a.bodies, b.bodies, strict=True):
        np.testing.assert_allclose(x.damage, y.damage, rtol=1e-15, atol=0)
        assert x.damage.max() == pytest.approx(0.2)
        assert not x.pitted.any()
    assert a.cycles == b.cycles == 2.0


def test_damage_column_moves_with_wear(tiny):
    scene, study = tiny
    cyc = PositionCycle(study, 2)
    st = initial_state(cyc)
    rng = np.random.default_rng(2)
    for bs in st.bodies:
        bs.damage[:] = rng.uniform(0, 0.5, size=bs.damage.shape)
    before = [bs.damage.copy() for bs in st.bodies]
    h0 = [bs.heights.copy() for bs in st.bodies]
    delta = 0.5 * cyc.z[1]
    apply_cycles(st, fake_result(cyc.grid.shape, cyc.z.size, 0.0, delta / 1e6), 1e6, cyc.z,
                 cyc.slab, "relaxed")
    for bs, d0, h in zip(st.bodies, before, h0, strict=True):
        np.testing.assert_allclose(bs.damage, shift_columns(d0, cyc.z, np.full(h.shape, delta)),
                                   rtol=1e-14)
        np.testing.assert_allclose(h - bs.heights, delta, rtol=1e-9)
        np.testing.assert_allclose(bs.wear, delta, rtol=1e-9)


def test_zero_sliding_gives_no_micropits(tiny):
    """S = 0: no micro-cycles (sliding counting), only the smooth macro cycle: A_p = 0."""
    scene, study = tiny
    cyc = PositionCycle(study, 1, k_lub=1e-11)
    assert cyc.cond.S == 0.0
    assert micro_cycles(cyc, 1, 20e-6) == 0.0
    st = initial_state(cyc)
    rec = run_block(cyc, st, scene.life)
    assert rec.Ap == (0.0, 0.0)
    assert rec.max_damage[0] < 1e-6
    assert rec.wear_max == (0.0, 0.0)              # no sliding, no Archard wear
    assert all((bs.damage >= 0).all() for bs in st.bodies)


def test_rainflow_steps_keep_the_slip_per_step_within_a_quarter_of_the_peak_spacing(tiny):
    """docs/model.md §4.4: relative slip per step 2b|S|/m ≤ λ_c/4, with the fewest such steps, and
    never fewer than asked; no refinement without sliding or without roughness."""
    _, study = tiny
    c = study.conditions[1]
    slip = 2.0 * c.b * abs(c.S)
    for lam in (0.5e-6, 2e-6, 5e-6, 10e-6):
        m = rainflow_steps(c, 8, lam)
        assert slip / m <= lam / 4 * (1 + 1e-12)
        assert m == 8 or slip / (m - 1) > lam / 4
    assert rainflow_steps(c, 8, 2e-6) > 8                 # 2b|S| is many λ_c/4 here
    assert rainflow_steps(c, 8, 1.0) == 8
    assert rainflow_steps(c, 8, float("inf")) == 8
    assert rainflow_steps(study.conditions[0], 8, 2e-6) == 8      # S = 0


def test_a_rainflow_life_run_refines_the_steps_and_counts_at_least_the_largest_cycle():
    """counting = "rainflow": the item raises its time steps to resolve the counterface (and
    says so), and the damage per load cycle of every point is at least that of its largest
    cycle, 1/N(τ_DV): periodic counting always closes the cycle through the maximum."""
    doc = tiny_doc()
    doc["fatigue"] = {"counting": "rainflow"}
    doc["window"]["steps"] = 3                     # 2b|S| = 56 µm needs 8 steps at λ_c 31 µm
    scene = scene_from_dict(doc, "tiny_rainflow.toml")
    said = []
    run = ItemRun(scene, WorkItem(0, 2, 0.0, 1.0, 0), log=said.append)
    assert run.cycle.steps > scene.window.steps
    assert len(said) == 1 and f"to {run.cycle.steps}" in said[0]
    res = evaluate(run.cycle, run.state)
    for bc in res.bodies:
        largest = run.cycle.woehler.damage(bc.tau_rough)
        assert largest.max() > 0
        assert (bc.damage_rate >= largest * (1 - 1e-12)).all()
        assert (bc.damage_rate >= 0).all()
    rec = run.run_block()
    assert 0 <= rec.Ap[0] <= 100 and 0 <= rec.Ap[1] <= 100


def test_sliding_pits_and_worn_volume(tiny):
    """S = 0.3 with wear: the heights lose exactly the wear plus the pit depths, the wear
    equals the sum of the increments applied, damage stays in [0, 1)."""
    scene, study = tiny
    cyc = PositionCycle(study, 2, k_lub=1e-11)
    how = "relaxed"                 # apply_cycles integrates a rate (implicit re-solves it)
    st = initial_state(cyc)
    h0 = [bs.heights.copy() for bs in st.bodies]
    res = evaluate(cyc, st)
    assert res.bodies[0].n_micro > 0
    increments = [np.zeros(cyc.grid.shape), np.zeros(cyc.grid.shape)]
    for n in (2e5, 3e5):
        res = evaluate(cyc, st)
        for i in range(2):
            increments[i] += res.bodies[i].wear.depth(n, how)
        apply_cycles(st, res, n, cyc.z, cyc.slab, how)
    for bs, h, inc in zip(st.bodies, h0, increments, strict=True):
        np.testing.assert_allclose(bs.wear, inc, rtol=1e-12, atol=0)
        np.testing.assert_allclose(h - bs.heights, bs.wear + bs.pit_depth, rtol=1e-9,
                                   atol=1e-18)
        assert (bs.damage >= 0).all() and (bs.damage < 1).all()
        assert bs.pitted.any() and bs.wear.max() > 0
        assert np.array_equal(bs.pit_depth > 0, bs.pitted)


def test_adaptive_split_for_wear_that_would_remove_the_roughness(tiny):
    scene, study = tiny
    cyc = PositionCycle(study, 2, k_lub=1e-8)      # removes microns per thousand cycles
    st = initial_state(cyc)
    res = evaluate(cyc, st)
    assert 1e6 * res.bodies[0].wear.rate.max() > 10 * st.bodies[0].rq0
    rec = run_block(cyc, st, scene.life)
    assert rec.sub_blocks == scene.life.max_splits
    st2 = initial_state(PositionCycle(study, 1))
    assert run_block(PositionCycle(study, 1), st2, scene.life).sub_blocks == 1      # k_lub 0


def test_a_block_records_the_largest_wear_step(tiny):
    """wear_step = the largest wear depth of one sub-block over the initial R_q: at most
    max_wear_fraction when the split can honour it, above it when max_splits stops it."""
    scene, study = tiny
    cycle = PositionCycle(study, 2, k_lub=1e-12)
    for splits, within in ((64, True), (1, False)):
        state = initial_state(cycle)
        life = dataclasses.replace(scene.life, max_splits=splits)
        rec = run_block(cycle, state, life)
        assert rec.wear_step > 0.0
        assert (rec.wear_step <= life.max_wear_fraction * (1 + 1e-9)) == within


def _one_rank(shape: tuple[int, int], layers: int = 3) -> Slab:
    """The one-rank slab of a window of ``shape`` cells (1 µm) and ``layers`` layers."""
    return Slab(SerialComm(), Grid(*shape, shape[0] * 1e-6, shape[1] * 1e-6), layers)


def _worn_pair(rate: np.ndarray, pitted: np.ndarray | None = None):
    """A state and cycle result whose only action is the explicit wear ``rate`` per cycle on
    both bodies (R_q 0.2 µm, no damage), for the split rule alone, and their one-rank slab."""
    shape = rate.shape
    pitted = np.zeros(shape, bool) if pitted is None else pitted
    bodies = tuple(BodyState(heights=np.zeros(shape), damage=np.zeros((3, *shape)),
                             pitted=pitted.copy(), wear=np.zeros(shape),
                             pit_depth=np.zeros(shape), rq0=0.2e-6) for _ in range(2))
    zero = np.zeros(shape)
    cycle = BodyCycle(damage_rate=np.zeros((3, *shape)), wear=WearRate(zero, rate, zero),
                      tau_rough=np.zeros((3, *shape)), tau_smooth=np.zeros((3, 1, 1)),
                      n_micro=0.0, lam_c=np.inf)
    return (LifeState(bodies=bodies),
            CycleResult(bodies=(cycle, cycle), phi=0.0, solid_fraction=0.0, steps=1, wall_s=0.0),
            _one_rank(shape))


def test_the_split_follows_the_shape_change_not_a_uniform_removal():
    """A uniform removal of 50 R_q per block changes nothing the contact sees: one sub-block.
    The same rate raised by 20 % on a quarter of the window is cut to the cycles in which that
    quarter has sunk by max_wear_fraction × R_q against the mean (the split of a wear
    integrated from one rate; the implicit wear ends its sub-blocks at the limit itself,
    test_implicit_wear.py)."""
    life = LifeSpec(max_splits=10_000, wear_integration="relaxed")
    mean = 50 * 0.2e-6 / life.block
    state, result, slab = _worn_pair(np.full((8, 8), mean))
    assert sub_block_cycles(state, result, life.block, life, slab) == life.block
    rate = np.full((8, 8), mean)
    rate[:4, :4] *= 1.2
    state, result, slab = _worn_pair(rate)
    n = sub_block_cycles(state, result, life.block, life, slab)
    change = shape_change(n * rate, np.ones(rate.shape, bool))
    assert change == pytest.approx(life.max_wear_fraction * 0.2e-6, rel=1e-5, abs=0)
    # the bump stands 0.15 × mean above the window's mean rate (a quarter of it at 1.2 × mean)
    assert n == pytest.approx(life.max_wear_fraction * 0.2e-6 / (0.15 * mean), rel=1e-5)


def test_pitted_columns_are_left_out_of_the_shape_change():
    """Pitted columns carry no load and so do not wear; they follow the wear around them in
    the contact (life._around_pits), so their missing wear is no change of shape."""
    rate = np.full((8, 8), 1e-12)
    pitted = np.zeros(rate.shape, bool)
    pitted[2:4, 5:7] = True
    rate[pitted] = 0.0
    assert shape_change(rate, ~pitted) == 0.0
    assert shape_change(rate, np.ones(rate.shape, bool)) > 0.9e-12
    life = LifeSpec(max_splits=10_000)
    state, result, slab = _worn_pair(rate, pitted)
    assert sub_block_cycles(state, result, life.block, life, slab) == life.block


def test_a_block_records_the_largest_pit_step(tiny, monkeypatch):
    """pit_step = the largest share of the window one sub-block newly pitted: at most
    max_pit_step when the split can honour it (so a block that pits the whole window takes
    at least 1/max_pit_step sub-blocks), the whole window when max_splits = 1. The cycle's
    rates are held fixed: the surface layer of column k fails at (k + ½)/N of the block."""
    scene, study = tiny
    cycle = PositionCycle(study, 2)
    block = 1e6
    nz, (nx, ny) = len(cycle.z), cycle.grid.shape
    rate = np.zeros((nz, nx, ny))
    rate[0] = (nx * ny / (block * (np.arange(nx * ny) + 0.5))).reshape(nx, ny)
    fixed = fake_result((nx, ny), nz, 0.0, 0.0)
    fixed = dataclasses.replace(fixed, bodies=tuple(
        dataclasses.replace(b, damage_rate=rate) for b in fixed.bodies))
    monkeypatch.setattr(cycle, "evaluate", lambda *a: fixed)
    for splits in (10_000, 1):
        state = initial_state(cycle)
        life = LifeSpec(block=block, max_splits=splits, max_damage_step=1e9)
        rec = run_block(cycle, state, life)
        assert all(bs.pitted.all() for bs in state.bodies)
        if splits == 1:
            assert rec.sub_blocks == 1 and rec.pit_step == 1.0
        else:
            assert 0 < rec.pit_step <= life.max_pit_step
            assert rec.sub_blocks >= 1 / life.max_pit_step


def test_the_smallest_sub_block_is_the_same_for_every_block_length():
    """A damage rate that breaks the damage limit in any sub-block (every point fails within
    100 cycles) is halved down to life.min_sub_block_M, the same at ΔN = 1 M and 0.25 M (a
    floor of ΔN/max_splits made the first pits, and A_p, depend on ΔN: docs/performance.md
    §14); ΔN/max_splits rules where it is larger."""
    state, result, slab = _worn_pair(np.zeros((10, 10)))
    rate = np.full((3, 10, 10), 1e-2)
    result = dataclasses.replace(result, bodies=tuple(
        dataclasses.replace(b, damage_rate=rate) for b in result.bodies))
    for block in (1e6, 0.25e6):
        life = LifeSpec(block=block)
        assert smallest_sub_block(life) == life.min_sub_block == 1000.0
        assert sub_block_cycles(state, result, block, life, slab) == 1000.0
    coarse = LifeSpec(block=1e6, max_splits=64)
    assert smallest_sub_block(coarse) == 1e6 / 64
    assert sub_block_cycles(state, result, 1e6, coarse, slab) == 1e6 / 64


def test_the_split_limits_the_share_of_newly_pitted_columns():
    """The pit cascade is resolved in time: 100 columns whose surface layer fails one after
    another, column k at (k + 1)/100 of the block, are split until a sub-block pits at most
    max_pit_step of the intact columns; columns already pitted do not count. Without the pit
    limit (and with the damage limit off) the whole block is one sub-block."""
    block = 1e6
    state, result, slab = _worn_pair(np.zeros((10, 10)))
    rate = np.zeros((3, 10, 10))
    rate[0] = (100.0 / (block * np.arange(1, 101))).reshape(10, 10)
    result = dataclasses.replace(result, bodies=tuple(
        dataclasses.replace(b, damage_rate=rate) for b in result.bodies))
    free = LifeSpec(block=block, max_splits=10_000, max_damage_step=1e9, max_pit_step=1.0)
    assert sub_block_cycles(state, result, block, free, slab) == block
    limited = dataclasses.replace(free, max_pit_step=0.01)
    # halving from ΔN: ΔN/64 pits column 0 only (1 %), ΔN/32 would pit three
    assert sub_block_cycles(state, result, block, limited, slab) == block / 64
    assert _new_pits(state, result, block / 32, slab) == pytest.approx(0.03)
    for bs in state.bodies:
        bs.pitted.reshape(-1)[:50] = True
    assert _new_pits(state, result, block, slab) == pytest.approx(0.5)
    assert _new_pits(state, result, block / 2, slab) == 0.0
    assert sub_block_cycles(state, result, block, limited, slab) == block / 2


# ---- wear integration over a sub-block (life.wear_integration) --------------------------------
def test_cell_self_compliance_matches_the_uniformly_loaded_square():
    """K₀ of the discrete operator against Love's centre displacement of a square of side s
    under uniform pressure, both bodies: 8 s asinh(1)/(π E')."""
    import math

    from micropit_hpc.lubrication.dry import ElasticHalfSpaces
    from micropit_hpc.spectral import Grid
    s, E = 3e-6, 230e9
    exact = 8 * s * math.asinh(1.0) / (math.pi * E)
    for n in (32, 128):
        k0 = ElasticHalfSpaces(Grid(n, n, n * s, n * s), E).self_compliance
        assert k0 == pytest.approx(exact, rel=0.035)
    # finer windows converge towards it (fewer periodic images, less spectral truncation)
    assert (abs(ElasticHalfSpaces(Grid(128, 128, 128 * s, 128 * s), E).self_compliance - exact)
            < abs(ElasticHalfSpaces(Grid(32, 32, 32 * s, 32 * s), E).self_compliance - exact))


def test_relaxed_wear_is_the_integral_of_the_relieved_rate():
    """depth(n) = ∫₀ⁿ [Δh_fluid + Δh_solid e^{−ρN}] dN, equal to n Δh where ρ = 0, to
    n Δh (1 − ρn/2) for ρn ≪ 1, bounded by n Δh_fluid + Δh_solid/ρ, non-decreasing in n."""
    from scipy.integrate import quad
    solid = np.array([2e-12, 2e-12, 5e-13, 0.0])
    fluid = np.array([1e-13, 0.0, 3e-14, 2e-13])
    relax = np.array([1e-4, 2e-5, 0.0, 0.0])
    w = WearRate(solid, fluid, relax)
    for n in (1e3, 2.5e5, 1e6):
        got = w.depth(n)
        for i, (s, f, r) in enumerate(zip(solid, fluid, relax, strict=True)):
            exact = quad(lambda N, s=s, f=f, r=r: f + s * np.exp(-r * N), 0, n,
                         epsabs=0, epsrel=1e-12, limit=200)[0]
            assert got[i] == pytest.approx(exact, rel=1e-9)
        assert (got <= w.depth(n, "explicit") * (1 + 1e-15)).all()
        np.testing.assert_array_equal(got[2:], w.depth(n, "explicit")[2:])
        bound = n * fluid + np.divide(solid, relax, out=np.full(4, np.inf), where=relax > 0)
        assert (got <= bound).all()
    tiny_step = 1e-2                                    # ρn = 1e-6
    np.testing.assert_allclose(w.depth(tiny_step)[:1], tiny_step * (fluid + solid
                               * (1 - relax * tiny_step / 2))[:1], rtol=1e-12)
    steps = [w.depth(n) for n in np.geomspace(1, 1e7, 30)]
    assert all((b >= a * (1 - 1e-14)).all() for a, b in itertools.pairwise(steps))
    with pytest.raises(ValueError, match="relaxed, explicit"):
        w.depth(1.0, "implicit")


def test_relaxed_wear_stays_within_the_elastic_relief_of_a_contact_spot(tiny):
    """A wear coefficient that would remove the roughness many times over in one block: the
    explicit update digs the contact spots hundreds of R_q deep; the relaxed one removes at most
    the film's share plus the spot's elastic deflection K₀ p/(1 + H_i/H_j) ≤ K₀ p_lim/2."""
    scene, study = tiny
    cyc = PositionCycle(study, 2, k_lub=1e-8)
    st = initial_state(cyc)
    res = evaluate(cyc, st)
    k0 = cyc.half_spaces.self_compliance
    H1, H2 = scene.body1.hardness, scene.body2.hardness
    for i, (bs, bc) in enumerate(zip(st.bodies, res.bodies, strict=True)):
        n = 1e6
        assert bc.wear.depth(n, "explicit").max() > 100 * bs.rq0
        relaxed = bc.wear.depth(n)
        Hi, Hj = (H1, H2) if i == 0 else (H2, H1)
        assert (relaxed <= n * bc.wear.fluid + k0 * cyc.p_lim / (1 + Hi / Hj) * (1 + 1e-9)).all()
        on_spots = bc.wear.relax > 0
        assert on_spots.any() and not (bc.wear.solid[~on_spots]).any()
