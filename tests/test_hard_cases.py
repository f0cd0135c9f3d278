"""Hard cases of the whole life path (issue 7): scene → contact conditions → PositionCycle /
ItemRun → life blocks, at the edges of the scene ranges.

Every case runs real blocks on a small window and checks, besides its own property, the
invariants of :func:`_check_step`, :func:`_check_cycle` and :func:`_check_block`: no NaN or inf
anywhere, each time step's mean pressure equal to the Hertz p̄_j of its window position, the
pressure within [0, p_lim], φ within [0, 1], damage in [0, 1), A_p in [0, 100] and equal to the
pitted share, heights lowered by exactly the wear plus the pit depths. A case that cannot be
computed must end in a :class:`MicropitError` whose message names what is wrong.
"""

from __future__ import annotations

import csv
import itertools
import math
import re
import tomllib

import numpy as np
import pytest
from helpers import SCENES, evaluate, process_averaged, tiny_doc, write_scene

from micropit_hpc.cli import main
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.errors import MicropitError, SceneError
from micropit_hpc.life import BlockRecord, initial_state, run_block
from micropit_hpc.lubrication.dry import ContactError
from micropit_hpc.plan import WorkItem, reference_half_width, window_grid
from micropit_hpc.scene import LifeSpec, scene_from_dict
from micropit_hpc.study import ItemRun
from micropit_hpc.surfaces import Topography
from micropit_hpc.surfaces.bodies import body_surface

#: Λ of tiny_doc(): h_c = 0.037 µm over the composite R_q of 0.16 and 0.21 µm.
TINY_LAMBDA = 0.037 / math.hypot(0.16, 0.21)


# ---- the invariants ---------------------------------------------------------------------------
def _hertz_mean(cycle: PositionCycle, step: int) -> float:
    """p̄_j = p0 √(1 − (x_c/b)²) at x_c = −b cos((j + ½)π/m) (cosine steps) or −b + 2b (j + ½)/m
    (uniform), from the conditions alone (docs/model.md §4)."""
    if cycle.spacing == "uniform":
        xi = 2.0 * (step + 0.5) / cycle.steps - 1.0
    else:
        xi = -math.cos((step + 0.5) * math.pi / cycle.steps)
    return cycle.cond.p0 * math.sqrt(max(0.0, 1.0 - xi * xi))


def _check_step(cycle: PositionCycle, f) -> None:
    """One solved time step: finite fields, the load balance, the pressure cap, φ in [0, 1]."""
    for name in ("pressure", "clearance", "friction", "traction1", "traction2"):
        assert np.isfinite(getattr(f, name)).all(), f"step {f.step}: {name} not finite"
    assert f.p_mean == pytest.approx(_hertz_mean(cycle, f.step), rel=1e-12, abs=0.0)
    assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-9, abs=0.0)
    assert f.pressure.min() >= 0.0
    if f.level != "smooth":
        assert f.pressure.max() <= cycle.p_lim * (1 + 1e-12)
    assert 0.0 <= f.phi <= 1.0
    assert f.solid.dtype == bool


def _check_cycle(res) -> None:
    """One load-cycle evaluation: finite, non-negative damage and wear rates."""
    assert 0.0 <= res.phi <= 1.0 and 0.0 <= res.solid_fraction <= 1.0
    for bc in res.bodies:
        assert np.isfinite(bc.damage_rate).all() and (bc.damage_rate >= 0.0).all()
        assert np.isfinite(bc.tau_rough).all() and np.isfinite(bc.tau_smooth).all()
        for part in (bc.wear.solid, bc.wear.fluid, bc.wear.relax):
            assert np.isfinite(part).all() and (part >= 0.0).all()
        assert math.isfinite(bc.n_micro) and bc.n_micro >= 0.0
        assert bc.lam_c > 0.0


def _check_block(rec: BlockRecord, state, heights0, life: LifeSpec, blocks: int) -> None:
    """A block's record and the state it leaves: finite, bounded, consistent."""
    for name in ("cycles", "phi", "wall_s", "wear_step", "pit_step"):
        assert math.isfinite(getattr(rec, name)), name
    for name in ("Ap", "max_damage", "wear_mean", "wear_max", "Rq", "n_micro"):
        assert all(math.isfinite(v) for v in getattr(rec, name)), name
    assert rec.cycles == pytest.approx(blocks * life.block, rel=1e-12)
    assert 1 <= rec.sub_blocks <= life.max_splits
    assert 0.0 <= rec.phi <= 1.0 and 0.0 <= rec.pit_step <= 1.0 and rec.wear_step >= 0.0
    for i, (bs, h0) in enumerate(zip(state.bodies, heights0, strict=True)):
        for name in ("heights", "damage", "wear", "pit_depth"):
            assert np.isfinite(getattr(bs, name)).all(), f"body {i + 1}: {name} not finite"
        assert (bs.damage >= 0.0).all() and (bs.damage < 1.0).all()
        assert (bs.wear >= 0.0).all() and (bs.pit_depth >= 0.0).all()
        assert np.array_equal(bs.pit_depth > 0.0, bs.pitted)
        assert 0.0 <= rec.Ap[i] <= 100.0
        assert rec.Ap[i] == pytest.approx(100.0 * bs.pitted.mean(), rel=1e-12, abs=0.0)
        assert rec.max_damage[i] == bs.damage.max()
        assert rec.wear_max[i] == bs.wear.max() and rec.Rq[i] == pytest.approx(bs.heights.std())
        removed = bs.wear + bs.pit_depth
        scale = max(float(np.abs(h0).max()), float(removed.max()), 1e-12)
        np.testing.assert_allclose(h0 - bs.heights, removed, rtol=0, atol=1e-12 * scale)


class Recorder:
    """Checks every time step and every load-cycle evaluation that a life block makes."""

    def __init__(self, cycle: PositionCycle, monkeypatch):
        self.cycle, self.steps, self.cycles, self.p_max = cycle, [], [], 0.0
        solve = cycle.solve_step

        def solve_step(step, *args, **kwargs):
            f = solve(step, *args, **kwargs)
            _check_step(cycle, f)
            self.steps.append((f.p_mean, f.phi, f.level))
            self.p_max = max(self.p_max, float(f.pressure.max()))
            return f

        cycle.solve_step = solve_step                   # evaluate calls the instance's
        evaluate = cycle.evaluate

        def checked_evaluate(*args, **kwargs):
            res = evaluate(*args, **kwargs)
            _check_cycle(res)
            self.cycles.append(res)
            return res

        monkeypatch.setattr(cycle, "evaluate", checked_evaluate)


def _blocks(cycle, state, life, monkeypatch, blocks=1) -> tuple[list[BlockRecord], Recorder]:
    """``blocks`` life blocks of one work item, every step, cycle and block checked."""
    rec = Recorder(cycle, monkeypatch)
    heights0 = [bs.heights.copy() for bs in state.bodies]
    records = []
    for k in range(1, blocks + 1):
        records.append(run_block(cycle, state, life))
        _check_block(records[-1], state, heights0, life, k)
    assert rec.steps and rec.cycles
    return records, rec


def _item(doc, k_lub=0.0, scale=1.0, position=1, name="hard.toml") -> ItemRun:
    return ItemRun(scene_from_dict(doc, name), WorkItem(0, position, k_lub, scale, 0))


def _run_item(run: ItemRun, monkeypatch, blocks=1):
    return _blocks(run.cycle, run.state, run.life, monkeypatch, blocks)


# ---- 1. Λ from 0.02 to 5 -----------------------------------------------------------------------
@pytest.mark.parametrize("lam", [0.02, 0.1, 0.5, 1.0, 2.99, 3.0, 5.0])
def test_lambda_range(lam, monkeypatch):
    """Λ 0.02–5 via roughness_scale: the item's Λ, mixed below 3, smooth from 3, sane blocks."""
    run = _item(tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,)), 1e-11, scale=TINY_LAMBDA / lam)
    assert run.cycle.cond.Lambda == pytest.approx(lam, rel=1e-12)
    assert run.cycle.level == ("mixed" if lam < 3.0 else "smooth")
    records, rec = _run_item(run, monkeypatch)
    if lam >= 3.0:                                   # full film: the fluid carries the load
        assert all(phi == 0.0 for _, phi, _ in rec.steps)
        top = max(_hertz_mean(run.cycle, j) for j in range(run.cycle.steps))
        assert rec.p_max == pytest.approx(top, rel=1e-12)
    if lam <= 0.05:                                  # the film cannot separate the roughness
        assert all(phi > 0.99 for p, phi, _ in rec.steps if p > 0.0)


def test_mixed_solutions_follow_lambda():
    """φ falls from 1 to ≈ 0 as Λ rises from 0.02 to 2.99; so does the solid area from Λ 0.2."""
    # below Λ ≈ 0.2 the contact is dry and rougher surfaces touch on less area
    doc = tiny_doc(slide_roll=(0.3,))
    phi, solid = [], []
    for lam in (0.02, 0.05, 0.2, 0.5, 1.0, 2.0, 2.99):
        run = _item(doc, scale=TINY_LAMBDA / lam)
        res = evaluate(run.cycle, run.state)
        _check_cycle(res)
        phi.append(res.phi)
        solid.append(res.solid_fraction)
    assert phi[0] > 0.99 and phi[-1] < 0.01 and solid[-1] < 0.01
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(phi)), phi
    assert all(b <= a + 1e-9 for a, b in itertools.pairwise(solid[2:])), solid


# ---- 2. p0 from 0.3 to 3.5 GPa -----------------------------------------------------------------
@pytest.mark.parametrize("p0", [0.3, 1.1, 2.0, 3.5])
def test_pressure_range(p0, monkeypatch):
    """p0 0.3–3.5 GPa (p_lim 4.2 GPa): every step balanced and capped, blocks sane."""
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    doc["disc"]["p0_GPa"] = p0
    run = _item(doc, 1e-11)
    assert run.cycle.cond.p0 == pytest.approx(p0 * 1e9, rel=1e-12)
    assert run.cycle.p_lim == pytest.approx(4.2e9)
    _run_item(run, monkeypatch)


@pytest.mark.slow
def test_pressure_above_the_cap_is_a_clear_error(tmp_path, capsys):
    """p0 4.5 GPa > p_lim: `micropit run` exits 2 naming scene, item, p̄ and p_lim."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["disc"]["p0_GPa"] = 4.5
    doc["life"]["cycles_M"] = 1.0
    scene = write_scene(tmp_path / "high.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "high.toml: item 0 (position 1" in err
    assert re.search(r"mean pressure [\d.]+ GPa ≥ p_lim 4\.2 GPa", err), err
    assert "Traceback" not in err


# ---- 3. |S| up to 2 ----------------------------------------------------------------------------
@pytest.mark.parametrize("S", [-1.999, -1.0, 1.5, 1.999])
def test_sliding_range(S, monkeypatch):
    """|S| up to 1.999: sane blocks; n_μ = 2b|u1 − u2|/(u_i λ_c), huge but finite when slow."""
    run = _item(tiny_doc(slide_roll=(S,), k_lub=(1e-11,)), 1e-11)
    c = run.cycle.cond
    assert c.S == pytest.approx(S, rel=1e-12)
    _, rec = _run_item(run, monkeypatch)
    first = rec.cycles[0]
    for i, u in enumerate((c.u1, c.u2)):
        bc = first.bodies[i]
        assert bc.n_micro == pytest.approx(2 * c.b * abs(c.u1 - c.u2) / (u * bc.lam_c),
                                           rel=1e-12)
    if abs(S) > 1.99:
        slow = 1 if c.u2 < c.u1 else 0
        assert first.bodies[slow].n_micro > 100 * first.bodies[1 - slow].n_micro


@pytest.mark.parametrize("S", [2.0, -2.0])
def test_pure_sliding_contact_and_stresses(S):
    """|S| = 2: every contact step balanced and finite, friction signs right, stresses finite."""
    study = contact_study(scene_from_dict(tiny_doc(slide_roll=(S,)), "slide.toml"))
    cycle = PositionCycle(study, 1)
    assert min(cycle.cond.u1, cycle.cond.u2) == 0.0
    for j in range(cycle.steps):
        f = cycle.solve_step(j)
        _check_step(cycle, f)
        np.testing.assert_array_equal(f.traction1, -math.copysign(1.0, S) * f.friction
                                      * f.pressure)
        np.testing.assert_array_equal(f.traction2, -f.traction1)
    for body in (1, 2):
        assert np.isfinite(cycle.stresses(f, body)).all()


@pytest.mark.parametrize("S", [2.0, -2.0])
def test_pure_sliding_life_is_a_clear_error_for_a_work_item(S):
    """|S| = 2 through ItemRun: a SceneError naming disc.slide_roll and |S| < 2, like the CLI."""
    # ItemRun is also the entry of postprocess/cycle_stages.py
    scene = scene_from_dict(tiny_doc(slide_roll=(S,)), "slide.toml")
    with pytest.raises(MicropitError) as err:
        run = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0))
        run.run_block()
    msg = str(err.value)
    assert "slide.toml" in msg and "disc.slide_roll" in msg and "|S| < 2" in msg


@pytest.mark.parametrize("where,value,key,allowed", [
    ("disc", 2.5, "disc.slide_roll[0] = 2.5", "each in [-2, 2]"),
    ("disc", -2.0001, "disc.slide_roll[0] = -2.0001", "each in [-2, 2]"),
    ("gear", 2.0, "gear.slide_roll_imposed = 2.0", "a number in [0, 2)"),
])
def test_sliding_beyond_pure_sliding_is_refused(where, value, key, allowed):
    """Disc |S| > 2 and gear slide_roll_imposed = 2 are refused naming key, value and range."""
    if where == "disc":
        doc = tiny_doc(slide_roll=(value,))
    else:
        doc = _gear_doc("linear", [27.0])
        doc["gear"]["slide_roll_imposed"] = value
    with pytest.raises(SceneError) as err:
        scene_from_dict(doc, "slide.toml")
    msg = str(err.value)
    assert msg.startswith("slide.toml: ") and key in msg and allowed in msg


# ---- 4. zero roughness -------------------------------------------------------------------------
@pytest.mark.parametrize("model,how", [("auto", "Rq"), ("auto", "kind"), ("smooth", "Rq"),
                                       ("dry", "Rq"), ("mixed", "kind")])
def test_zero_roughness(model, how, monkeypatch):
    """Two smooth bodies, every level: uniform p̄, n_μ = 0, no pits, flat uniform wear."""
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    for body in ("body1", "body2"):
        if how == "Rq":
            doc[body]["Rq_um"] = 0.0
        else:
            doc[body]["surface"] = {"kind": "smooth"}
    doc["lubrication"] = {"model": model}
    run = _item(doc, 1e-11)
    assert run.cycle.level == ("smooth" if model == "auto" else model)
    assert (run.cycle.cond.Lambda == math.inf) == (how == "Rq")
    records, rec = _run_item(run, monkeypatch, blocks=2)
    cycle = run.cycle
    for j in range(cycle.steps):
        f = cycle.solve_step(j)
        assert np.ptp(f.pressure) <= 1e-12 * f.p_mean
    for r in records:
        assert r.Ap == (0.0, 0.0) and r.n_micro == (0.0, 0.0)
        assert max(r.max_damage) < 1e-6
        assert max(r.wear_max) > 0.0
        assert max(r.Rq) <= 1e-9 * max(r.wear_max)


@pytest.mark.slow
def test_zero_roughness_run_writes_an_infinite_lambda(tmp_path):
    """`micropit run`, two smooth bodies: Λ = λ_GF = inf in the outputs, the rest finite."""
    import h5py

    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    doc["body1"]["Rq_um"] = doc["body2"]["Rq_um"] = 0.0
    scene = write_scene(tmp_path / "smooth.toml", doc)
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 0
    with open(tmp_path / "out" / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * 2
    for r in rows:
        assert float(r["Lambda"]) == math.inf and float(r["Ap_pct"]) == 0.0
        for k in ("S", "p0_GPa", "cycles", "max_damage", "wear_um", "Rq_um"):
            assert math.isfinite(float(r[k])), k
    with h5py.File(tmp_path / "out" / "results.h5", "r") as f:
        assert f["items/Lambda"][0] == math.inf and f["items/lambda_GF"][0] == math.inf
        assert np.isfinite(f["items/hc"][()]).all()


# ---- 5. very rough surfaces --------------------------------------------------------------------
@pytest.mark.parametrize("model", ["auto", "dry"])
def test_very_rough_surfaces(model, monkeypatch):
    """R_q = 50 h̄ per body (Λ 0.014): φ = 1 at every loaded step, balanced, capped, sane."""
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    doc["body1"]["Rq_um"] = doc["body2"]["Rq_um"] = 50 * 0.037
    doc["lubrication"] = {"model": model}
    run = _item(doc, 1e-11)
    assert run.cycle.cond.Lambda == pytest.approx(1 / (50 * math.sqrt(2)), rel=1e-9)
    assert run.cycle.level == ("mixed" if model == "auto" else "dry")
    _, rec = _run_item(run, monkeypatch)
    assert all(phi == 1.0 for p, phi, _ in rec.steps if p > 0.0)
    assert rec.p_max == pytest.approx(run.cycle.p_lim, rel=1e-12)


# ---- 6. a single spike of 10 R_q ---------------------------------------------------------------
SPIKE = (10, 7)
#: The spike's cells: three along x (a plateau the linear transfer into each body's frame keeps
#: at p_lim; a one-cell spike is smeared over two cells at fractional slips and halves its
#: peak), one across.
SPIKE_CELLS = (slice(9, 12), 7)


def _spike_scene(tmp_path, base: str):
    """tiny_doc at Λ = 1 (no pits without the spike) on a 200 µm window, k_lub = 0; for the
    smooth base body 1 is a measured map (kind = "file") holding only the spike."""
    doc = tiny_doc(slide_roll=(0.3,))
    for body, rq in (("body1", 0.16), ("body2", 0.21)):
        doc[body]["Rq_um"] = rq * TINY_LAMBDA
    doc["window"].update(length_x_um=200.0, length_y_um=200.0)
    spike = 10 * doc["body1"]["Rq_um"] * 1e-6
    if base == "smooth":
        h = np.zeros((32, 32))
        h[SPIKE_CELLS] = spike
        np.save(tmp_path / "spike.npy", h)
        doc["body1"]["Rq_um"] = float(h.std()) * 1e6
        doc["body1"]["surface"] = {"kind": "file", "file": "spike.npy",
                                   "spacing_um": [6.25, 6.25], "detrend": "none",
                                   "periodise": "none"}
    return scene_from_dict(doc, str(tmp_path / "spike.toml")), spike


@pytest.mark.parametrize("base", ["rough", "smooth", "none"])
def test_single_spike(tmp_path, base, monkeypatch):
    """A 10 R_q spike on body 1 (3 cells along x, 1 across) is capped at p_lim and damages
    body 2 only along its track (by orders of magnitude more than anywhere else; pits, if
    any, only there); none, no pits."""
    # body 1 rough (surfaces= of PositionCycle) or smooth (a measured .npy map, kind = "file"),
    # against rough body 2 at Λ = 1; the spike pits the row it ploughs on body 2 and nothing
    # else there, body 1 at most at the spike; "none": the same surfaces without the spike
    scene, spike = _spike_scene(tmp_path, base)
    study = contact_study(scene)
    grid = window_grid(scene, reference_half_width(study))
    surfaces = None
    if base != "smooth":
        rough = body_surface(scene, 1, grid)
        h = rough.heights.copy()
        if base == "rough":
            h[SPIKE_CELLS] += spike
        surfaces = (Topography(h, grid.dx, grid.dy, "spiked"), body_surface(scene, 2, grid))
    cycle = PositionCycle(study, 1, surfaces=surfaces)
    if base == "smooth":                       # the map read as written: the spike alone
        assert cycle.surfaces[0].heights[SPIKE] == pytest.approx(spike, rel=1e-12)
        assert np.count_nonzero(cycle.surfaces[0].heights) == 3
    state = initial_state(cycle)
    records, rec = _blocks(cycle, state, scene.life, monkeypatch)
    pitted = state.bodies[0].pitted
    if base == "none":
        assert rec.p_max < cycle.p_lim and not pitted.any() and records[0].Ap == (0.0, 0.0)
        return
    assert rec.p_max == pytest.approx(cycle.p_lim, rel=1e-12)
    b2 = state.bodies[1]                            # body 2 slides under the spike along x
    assert not np.delete(b2.pitted, SPIKE[1], axis=1).any()
    risk = np.where(b2.pitted, np.inf, b2.damage.max(axis=0))
    assert risk[:, SPIKE[1]].max() > 100 * np.delete(risk, SPIKE[1], axis=1).max()
    ix, iy = np.nonzero(pitted)
    dx = np.minimum(np.abs(ix - SPIKE[0]), grid.nx - np.abs(ix - SPIKE[0]))
    assert (dx <= 1).all() and (iy == SPIKE[1]).all()


# ---- 7. wear that removes the roughness in one block -------------------------------------------
@pytest.mark.parametrize("integration", ["relaxed", "explicit"])
def test_wear_that_removes_the_roughness_in_one_block(integration, monkeypatch):
    """k_lub 1e-8 s (wear ≫ R_q per block): split floored, the excess flagged, blocks sane."""
    # a surface the wear roughened (R_q > 2 R_q0) must always come with wear_step > the limit
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-8,))
    doc["life"]["wear_integration"] = integration
    # 5 cosine steps: at 4 (relaxed) the dry contact of the second block's worn surface stops
    # at a residual of 1e-3 after 5000 iterations (5, 8 and 4 or 8 uniform steps converge)
    doc["window"]["steps"] = 5
    run = _item(doc, 1e-8)
    first = evaluate(run.cycle, run.state)
    for bs, bc in zip(run.state.bodies, first.bodies, strict=True):
        assert bc.wear.depth(run.life.block, integration).max() > 10 * bs.rq0
    rq0 = [bs.rq0 for bs in run.state.bodies]
    records, _ = _run_item(run, monkeypatch, blocks=2)
    assert records[0].sub_blocks == run.life.max_splits
    assert records[0].wear_step > run.life.max_wear_fraction
    for r in records:
        for rq, rq_0 in zip(r.Rq, rq0, strict=True):
            if rq > 2 * rq_0:
                assert r.wear_step > run.life.max_wear_fraction


@pytest.mark.parametrize("splits", [1, 4])
def test_wear_coefficient_at_the_top_of_its_range(splits, monkeypatch):
    """k_lub 1e-3 s (schema max): sane flagged blocks, or a ContactError whose reason is true."""
    # "true": the residual it quotes exceeds the tolerance, or the iteration budget is used up
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-3,))
    doc["life"]["max_splits"] = splits
    run = _item(doc, 1e-3)
    try:
        records, _ = _run_item(run, monkeypatch, blocks=1)
    except ContactError as e:
        msg = str(e)
        assert "lubrication.max_iterations" in msg
        m = re.search(r"relative residual (\S+) > tolerance (\S+) after (\d+) iterations", msg)
        assert m, msg
        residual, tol, used = float(m[1]), float(m[2]), int(m[3])
        assert residual > tol or used >= run.cycle.scene.lubrication.max_iter, msg
        return
    assert records[0].wear_step > run.life.max_wear_fraction


# ---- 8. non-square and prime grids -------------------------------------------------------------
@pytest.mark.parametrize("nx,ny", [(127, 64), (31, 17), (9, 3)])
def test_prime_and_non_square_windows(nx, ny, monkeypatch):
    """Prime/non-square windows: shapes, whole-column A_p, σ_zz(0) = −p̃, σ_xz(0) = −q̃ (the
    tractions averaged over the process area, tests/helpers.process_averaged), sane."""
    doc = tiny_doc(slide_roll=(0.3,), k_lub=(1e-11,))
    doc["window"] = {"n": nx, "ny": ny, "steps": 4}
    doc["stress"] = {"layers": 4}
    doc["life"]["max_splits"] = 2
    run = _item(doc, 1e-11)
    cycle = run.cycle
    g = cycle.grid
    assert g.shape == (nx, ny) and all(s.heights.shape == (nx, ny) for s in cycle.surfaces)
    f = cycle.solve_step(1)
    sigma = cycle.stresses(f, 1)
    assert sigma.shape == (6, 4, nx, ny) and cycle.z[0] == 0.0
    p, q = process_averaged(cycle, *cycle.material_tractions(f, 1))
    assert np.abs(sigma[2, 0] + p).max() < 1e-9 * cycle.cond.p0
    assert np.abs(sigma[4, 0] + q).max() < 1e-9 * cycle.cond.p0
    records, _ = _run_item(run, monkeypatch)
    for bs, ap in zip(run.state.bodies, records[0].Ap, strict=True):
        assert bs.damage.shape == (4, nx, ny)
        assert ap * nx * ny / 100 == pytest.approx(round(ap * nx * ny / 100), abs=1e-9)


@pytest.mark.parametrize("window,message", [
    ({"nx": 127}, "unknown key 'window.nx'; did you mean 'n'?"),
    ({"n": 7}, "window.n = 7: out of range (allowed: an integer in [8, 8192])"),
    ({"n": 127.5}, "window.n = 127.5: expected an integer"),
    ({"n": 127, "ny": 0}, "window.ny = 0: out of range (allowed: an integer in ["),
    ({"n": 127, "ny": 8193}, "window.ny = 8193: out of range (allowed: an integer in ["),
])
def test_window_sizes_outside_the_schema_are_refused(window, message):
    """A window key or size outside the schema is refused naming key, value and range."""
    doc = tiny_doc()
    doc["window"] = window
    with pytest.raises(SceneError) as err:
        scene_from_dict(doc, "grid.toml")
    assert str(err.value).startswith("grid.toml: ") and message in str(err.value)


def test_a_one_row_window_runs_or_is_refused_by_its_key(monkeypatch):
    """window.ny = 1 (allowed by the schema) either runs or is refused naming window.ny."""
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"] = {"n": 32, "ny": 1, "steps": 4}
    try:
        scene = scene_from_dict(doc, "row.toml")
    except SceneError as e:
        assert "window.ny = 1" in str(e) and "allowed" in str(e)
        return
    run = ItemRun(scene, WorkItem(0, 1, 0.0, 1.0, 0))
    assert run.cycle.grid.shape == (32, 1)
    _run_item(run, monkeypatch)


# ---- 9. the ends of the path of contact of a gear ----------------------------------------------
def _gear_doc(sharing: str, roll_deg: list[float]) -> dict:
    """scenes/paper_gear_z23.toml on a 32² window, 4 steps, 4 layers, one patch and one
    block of 1 M cycles at k_lub = 1e-11 s, at the given roll angles."""
    doc = tomllib.loads((SCENES / "paper_gear_z23.toml").read_text())
    doc["study"]["patches"] = 1
    doc["gear"]["load_sharing"] = sharing
    doc["positions"] = {"roll_angle_deg": roll_deg}
    doc["window"].update(n=32, steps=4)
    doc["stress"]["layers"] = 4
    doc["wear"]["k_lub_s"] = [1e-11]
    doc["life"].update(cycles_M=1.0, max_splits=4)
    return doc


def _path_ends() -> tuple[float, float]:
    """Roll angles of A and E [deg] of the paper's z = 23 pair."""
    mesh = contact_study(scene_from_dict(_gear_doc("none", [27.0]), "g.toml")).mesh
    return tuple(math.degrees(v) for v in mesh.position_range("roll_angle"))


@pytest.mark.parametrize("sharing,end,offset_deg,rq_um", [
    ("linear", "A", 1e-4, 2.892),
    ("linear", "A", 1e-9, 2.892),
    ("linear", "E", 1e-9, 2.892),
    ("linear", "A", 1e-6, 0.0),
    ("none", "A", 0.0, 2.892),
    ("iso_unmodified", "E", 0.0, 2.892),
])
def test_gear_path_ends(sharing, end, offset_deg, rq_um, monkeypatch):
    """Gear positions at/near A and E: near-zero load (linear) or loaded ends run sanely."""
    # linear load sharing: 1e-4° to 1e-9° inside A or E, no pits and damage ≈ 0 expected;
    # `none` and `iso_unmodified`: the end point itself, under load; rough and smooth flanks
    A, E = _path_ends()
    roll = A + offset_deg if end == "A" else E - offset_deg
    doc = _gear_doc(sharing, [roll])
    doc["body1"]["Rq_um"] = doc["body2"]["Rq_um"] = rq_um
    run = _item(doc, 1e-11, name="ends.toml")
    c = run.cycle.cond
    expected_share = {"linear": None, "none": 1.0, "iso_unmodified": 1 / 3}[sharing]
    if expected_share is None:
        assert 0.0 < c.load_share < 1e-4 and c.p0 < 0.01e9
    else:
        assert c.load_share == pytest.approx(expected_share, rel=1e-12)
    assert (c.S < 0) == (end == "A")
    records, _ = _run_item(run, monkeypatch)
    if sharing == "linear":
        assert records[0].Ap == (0.0, 0.0) and max(records[0].max_damage) < 1e-6


@pytest.mark.slow
def test_gear_path_ends_through_the_run_command(tmp_path, capsys):
    """`micropit run` 1e-9° inside A and E: exit 0 with finite rows, or exit 2; no traceback."""
    # p0 ≈ 17 kPa, Λ ≈ 3.1: the full-film (smooth) level
    A, E = _path_ends()
    doc = _gear_doc("linear", [A + 1e-9, E - 1e-9])
    scene = write_scene(tmp_path / "ends.toml", doc)
    rc = main(["run", str(scene), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc in (0, 2) and "Traceback" not in err
    if rc == 2:
        assert "ends.toml" in err
        return
    with open(tmp_path / "out" / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * 2
    for r in rows:
        assert all(math.isfinite(float(r[k])) for k in ("Ap_pct", "max_damage", "wear_um"))
        assert float(r["Ap_pct"]) == 0.0
