"""The travelling window of one position, one time step end to end, and `micropit snapshot`."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
import types

import numpy as np
import pytest
from helpers import ROOT, SCENES, SMALL, gear_scene, process_averaged

from micropit_hpc import cycle as cycle_module
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.errors import MicropitError, SceneError
from micropit_hpc.fatigue.dangvan import dang_van
from micropit_hpc.fatigue.rainflow import rainflow_damage
from micropit_hpc.mechanics.halfspace import history_chunk_layers
from micropit_hpc.mechanics.hertz_field import line_contact_stress
from micropit_hpc.plan import reference_half_width
from micropit_hpc.scene import load_scene


def test_window_kinematics(tmp_path):
    """x_c from −b to +b, relative slip over the transit 2b|S| (docs/model.md §4); ``uniform``
    steps at t_j = (j+½)t_f/m, ``cosine`` (the default) at x_c = −b cos θ_j, θ_j = (j+½)π/m,
    each weighing its share of the transit time."""
    uniform = SMALL.replace("steps = 4", 'steps = 4\nstep_spacing = "uniform"')
    for spacing, extra in (("cosine", SMALL), ("uniform", uniform)):
        study = contact_study(load_scene(gear_scene(tmp_path, extra=extra, name=spacing)))
        cyc = PositionCycle(study, 3, steps=4)
        c = cyc.cond
        m = cyc.steps
        assert cyc.spacing == spacing
        first = -c.b + c.b / m if spacing == "uniform" else -c.b * math.cos(math.pi / (2 * m))
        assert cyc.centre(cyc.time(0)) == pytest.approx(first, rel=1e-12)
        assert cyc.centre(cyc.time(m - 1)) == pytest.approx(-first, rel=1e-12)
        # the rounding bound of m ≤ 7 weights (a sine product each, 2 ulp) and their sum:
        # below 7 · 3 · 1.1e-16 ≈ 2.3e-15
        assert cyc.weights.sum() == pytest.approx(1.0, rel=1e-14)
        # a step's weight is the time between the midpoints of its neighbours, in t_f
        edges = [0.0] + [0.5 * (cyc.time(j) + cyc.time(j + 1)) for j in range(m - 1)] + [cyc.t_f]
        if spacing == "cosine":      # the cells θ_j ± π/2m, not the midpoints in t
            edges = [0.5 * cyc.t_f * (1 - math.cos(j * math.pi / m)) for j in range(m + 1)]
        assert cyc.weights == pytest.approx(np.diff(edges) / cyc.t_f, rel=1e-12)
        slip = cyc.slip(1, cyc.t_f) - cyc.slip(2, cyc.t_f)
        assert abs(slip) == pytest.approx(2 * c.b * abs(c.S), rel=1e-12)
        assert cyc.grid.lx == pytest.approx(2 * reference_half_width(study), rel=1e-12)
        assert reference_half_width(study) == pytest.approx(study.conditions[5].b, rel=2e-3)
        with pytest.raises(MicropitError, match="steps 0 to 3"):
            cyc.time(4)
        # p̄ of a step and of its mirror: one number, p_H(x_c) of the first, within rounding
        # of p_H at the mirror's own x_c (a square root of 1 − x²/b²: a few ulp)
        for j in range(m):
            p_j = cyc.step_mean_pressure(j)
            assert p_j == cyc.step_mean_pressure(m - 1 - j)
            assert p_j == pytest.approx(cyc.mean_pressure(cyc.centre(cyc.time(j))), rel=1e-14)
            assert cyc.mirror_order(j) == (min(j, m - 1 - j), j)
    with pytest.raises(MicropitError, match="positions 1 to 11"):
        PositionCycle(study, 12)


def test_steps_go_to_the_ranks_in_mirror_pairs_where_that_keeps_them_even(tmp_path):
    """``step_owners``: the pairs (j, m − 1 − j) round robin where no rank then gets more than
    ⌈m/R⌉ steps, else the steps round robin (the balance of the contact's share comes first)."""
    study = contact_study(load_scene(gear_scene(tmp_path)))
    for m, ranks, paired in ((63, 2, True), (5, 2, True), (40, 4, True), (20, 5, True),
                             (20, 4, False), (20, 20, False), (7, 1, True)):
        owners = PositionCycle(study, 3, steps=m).step_owners(ranks)
        counts = [owners.count(r) for r in range(ranks)]
        assert max(counts) == -(-m // ranks) and sum(counts) == m
        together = all(owners[j] == owners[m - 1 - j] for j in range(m))
        assert together == paired, (m, ranks)
        if not paired:
            assert owners == [j % ranks for j in range(m)]


def test_mirror_steps_share_their_dispersion_relation(tmp_path, monkeypatch):
    """The contact solves the steps in mirror order (j next to m − 1 − j, which have one p̄):
    the dispersion relation of the mixed model is solved once per pair and body, and the
    factors each step gets are those computed afresh for it, bit for bit."""
    from micropit_hpc.lubrication import mixed

    calls = []
    solve = mixed.solve_dispersion_rows
    monkeypatch.setattr(mixed, "solve_dispersion_rows",
                        lambda *a, **k: calls.append(1) or solve(*a, **k))
    monkeypatch.setattr(mixed, "FACTOR_CACHE_BYTES", 0)     # the last (body, p̄) only
    study = contact_study(load_scene(gear_scene(tmp_path)))
    cyc = PositionCycle(study, 3, steps=5)
    assert cyc.level == "mixed"
    cyc._contact_steps(None, None)
    assert len(calls) == 2 * 3                  # pairs (0, 4), (1, 3) and step 2; two bodies
    model = cyc.mixed
    for body in (1, 2):
        p_mean, t = cyc.step_mean_pressure(3), cyc.time(3)
        model.cached_factors(body, cyc.step_mean_pressure(1), cyc.time(1))
        got = model.cached_factors(body, p_mean, t)
        h_a, h_t, D = model.lubricated_factors(body, p_mean, t)
        for u, v in zip(got, (h_a, h_t - h_a, D), strict=True):
            assert np.array_equal(u, v)


def _contact(b: float, S: float):
    """What the step rule reads of a contact: its semi-width and slide-to-roll ratio."""
    return types.SimpleNamespace(b=b, S=S)


def test_slip_steps_bound_the_relative_slip_per_step_by_the_fewest_steps():
    """docs/model.md §4: the largest step slips the surfaces past each other by at most the
    length asked, uniform 2b|S|/m, cosine at most 2b|S| sin(π/2m), with the fewest such steps: b =
    100 µm, |S| = 0.4 (2b|S| = 80 µm) against 3.2 µm cells is 25 cells, so 25 uniform steps
    and ⌈π/(2 asin(1/25))⌉ = 40 cosine ones (39 steps, an odd number, have a
    largest share sin(π/78) = 0.0403 > 1/25); none without sliding."""
    c, dx = _contact(100e-6, -0.4), 3.2e-6
    assert cycle_module.slip_steps(c, dx, "uniform") == 25
    assert cycle_module.slip_steps(c, dx, "cosine") == 40
    assert math.pi / (2 * math.asin(1 / 25)) == pytest.approx(39.26, abs=0.01)
    assert math.sin(math.pi / 78) > 1 / 25
    for spacing in cycle_module.STEP_SPACINGS:
        for length in (0.3e-6, 1e-6, 3.2e-6, 7e-6, 50e-6):
            m = cycle_module.slip_steps(c, length, spacing)
            largest = 2 * c.b * abs(c.S) * cycle_module.step_weights(m, spacing).max()
            assert largest <= length * (1 + 1e-12)
            if m > 1:
                fewer = 2 * c.b * abs(c.S) * cycle_module.step_weights(m - 1, spacing).max()
                assert fewer > length
        assert cycle_module.slip_steps(c, 1.0, spacing) == 1             # slip < one length
        assert cycle_module.slip_steps(_contact(100e-6, 0.0), dx, spacing) == 1     # S = 0
        # 7 weights of 2 ulp each and their sum: the rounding bound is about 2.3e-15
        assert cycle_module.step_weights(7, spacing).sum() == pytest.approx(1.0, rel=1e-14)


def _step_scene(**window):
    from helpers import tiny_doc

    from micropit_hpc.scene import scene_from_dict

    doc = tiny_doc()
    doc["window"].pop("steps_per_peak_spacing")     # the scene's default rule
    doc["window"].update(window)
    return scene_from_dict(doc, "tiny_steps.toml")


def test_cycle_steps_take_the_strictest_of_the_floor_the_slip_and_rainflow():
    """m = max(window.steps, the slip rule λ_c/24, rainflow's λ_c/4 rule), and the reason
    names the rule that set it (docs/model.md §4): 2b|S| = 80 µm at λ_c = 48 µm asks at most
    2 µm per step, 40 uniform steps or 63 cosine ones (π/(2 asin(2/80)) = 62.8; 62 steps, an
    even number, have a largest share ½ sin(π/62) = 0.0253 > 2/80)."""
    c, lam = _contact(100e-6, 0.4), 48e-6
    scene = _step_scene(steps=20)
    assert scene.window.step_spacing == "cosine" and scene.window.steps_per_peak_spacing == 24
    m, why = cycle_module.cycle_steps(scene, c, lam)
    assert m == 63 and "relative slip per step ≤ λ_c/24" in why
    assert math.sin(math.pi / 126) <= 2 / 80 < 0.5 * math.sin(math.pi / 62)
    uniform = _step_scene(steps=20, step_spacing="uniform")
    assert cycle_module.cycle_steps(uniform, c, lam)[0] == 40
    assert cycle_module.cycle_steps(_step_scene(steps=64), c, lam) == (64, "")    # the floor
    assert cycle_module.cycle_steps(scene, _contact(100e-6, 0.0), lam) == (20, "")  # S = 0
    assert cycle_module.cycle_steps(scene, c, math.inf) == (20, "")               # smooth
    assert cycle_module.cycle_steps(_step_scene(steps=20, steps_per_peak_spacing=7.0), c,
                                    lam)[0] == 20          # λ_c/7: 19 steps would do

    def rainflow(**window):
        s = _step_scene(**window)
        return dataclasses.replace(s, fatigue=dataclasses.replace(s.fatigue,
                                                                  counting="rainflow"))
    # rainflow's λ_c/4 is stricter than λ_c/2 and wins; λ_c/24 is stricter than rainflow's
    loose = rainflow(steps=20, steps_per_peak_spacing=2.0)
    m, why = cycle_module.cycle_steps(loose, c, 8e-6)
    assert m == cycle_module.slip_steps(c, 2e-6, "cosine") == 63 and "rainflow" in why
    assert m == cycle_module.rainflow_steps(c, 20, 8e-6, "cosine")
    assert cycle_module.cycle_steps(rainflow(steps=20), c, lam) == cycle_module.cycle_steps(
        scene, c, lam)


def test_the_cycle_uses_the_raised_steps_and_the_study_says_so():
    """A PositionCycle without steps and an ItemRun take the rule's m (more than the floor on
    the tiny disc at |S| = 0.3: 2b|S| is several λ_c), solve that many contacts in a load
    cycle and log the raise."""
    from micropit_hpc.plan import WorkItem
    from micropit_hpc.study import ItemRun

    scene = _step_scene(steps=3)
    study = contact_study(scene)
    c = study.conditions[1]
    cyc = PositionCycle(study, 2)
    lam = cycle_module.counterface_spacing(scene, cyc.surfaces, cyc.grid.dx)
    m, why = cycle_module.cycle_steps(scene, c, lam)
    assert cyc.steps == m > 3 and why
    said = []
    run = ItemRun(scene, WorkItem(0, 2, 0.0, 1.0, 0), base=study, log=said.append)
    assert run.cycle.steps == m
    assert len(said) == 1 and f"from 3 to {m}" in said[0] and "slip per step" in said[0]
    solved = []
    res = run.cycle.evaluate(run.surfaces, on_step=solved.append)
    assert res.steps == m and solved == list(range(1, m + 1))
    assert PositionCycle(study, 1).steps == 3             # no sliding: the floor
    rolling = ItemRun(scene, WorkItem(1, 1, 0.0, 1.0, 0), base=study, log=said.append)
    assert rolling.cycle.steps == 3 and len(said) == 1    # and nothing to say


def test_mixed_step_balances_the_load_and_stresses_match_the_surface(tmp_path):
    """One mixed step of the default gear scene: the mean pressure is p̄_j, the pressure is
    within [0, p_lim], and the assembled stress of body 1 at z = 0 is −p of the pressure moved
    into the body's material frame (macro field at the window centre plus the micro field of
    the fluctuation): the micro and macro parts and the frame transfer fit."""
    study = contact_study(load_scene(gear_scene(tmp_path)))
    cyc = PositionCycle(study, 3)
    assert cyc.level == "mixed"
    f = cyc.solve_step(1)
    assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-10)
    assert 0.0 <= f.pressure.min() and f.pressure.max() <= cyc.p_lim * (1 + 1e-12)
    assert 0.0 <= f.phi <= 1.0
    assert np.array_equal(f.friction == 0.11, f.solid)
    # traction on body 1 points towards body 2's relative velocity: S < 0 ⇒ u2 > u1 ⇒ +x
    assert cyc.cond.S < 0 and f.traction1.sum() > 0 and f.traction2.sum() < 0
    sigma = cyc.stresses(f, 1)
    assert sigma.shape == (6, 4, 32, 32) and np.isfinite(sigma).all()
    p, _ = cyc.material_tractions(f, 1)
    # the criterion sees the stresses of the tractions averaged over the process area (the
    # default ℓ = 5 µm): at z = 0, σ_zz = −p̃, p̃ the pressure filtered by its kernel
    assert cyc.scene.fatigue.process_length == 5.0 * 1e-6       # a file's 5 µm, bit for bit
    (p_avg,) = process_averaged(cyc, p)
    assert np.abs(p_avg - p).max() > 0.01 * cyc.cond.p0          # a real cut of the map
    assert np.abs(sigma[2, 0] + p_avg).max() < 1e-9 * cyc.cond.p0
    # below the surface the uniform part is the Hertz field at the window centre
    mu = f.traction1.sum() / f.pressure.sum()
    macro = line_contact_stress(f.x_c, cyc.z, cyc.cond.b, cyc.cond.p0, mu, 0.3)[2]
    np.testing.assert_allclose(sigma[2].mean(axis=(1, 2)), macro, rtol=0, atol=1e-6 * cyc.cond.p0)


def test_thick_film_is_smooth_and_dry_level_is_a_contact(tmp_path):
    path = gear_scene(tmp_path, extra=SMALL + "\n[lubrication]\nmodel = \"dry\"\n")
    cyc = PositionCycle(contact_study(load_scene(path)), 5)
    f = cyc.solve_step(2)
    assert f.level == "dry" and f.phi == 1.0 and f.solid.any()
    assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-10)
    thick = gear_scene(tmp_path, extra=SMALL + "\n[lubrication]\nauto_lambda = 0.1\n")
    cyc = PositionCycle(contact_study(load_scene(thick)), 5)
    f = cyc.solve_step(2)
    assert f.level == "smooth" and not f.solid.any() and np.ptp(f.pressure) == 0.0


def test_mixed_needs_the_eyring_stress(tmp_path):
    path = gear_scene(tmp_path, drop=("eyring_stress_MPa = 9.0",))
    with pytest.raises(SceneError, match=r"missing key 'lubricant.eyring_stress_MPa'.*auto"):
        PositionCycle(contact_study(load_scene(path)), 3)


def test_same_seed_same_step_other_seed_differs(tmp_path):
    study = contact_study(load_scene(gear_scene(tmp_path)))
    a = PositionCycle(study, 4).solve_step(1)
    b = PositionCycle(study, 4).solve_step(1)
    assert np.array_equal(a.pressure, b.pressure)
    other = gear_scene(tmp_path, extra=SMALL.replace("steps = 4", "steps = 4\nseed = 2"))
    c = PositionCycle(contact_study(load_scene(other)), 4).solve_step(1)
    assert not np.array_equal(a.pressure, c.pressure)


def test_history_chunk_layers_follows_the_budget():
    # one layer of 20 steps at 64²: 20 × 6 × 8 × 4096 B = 3.75 MiB
    layer = 48.0 * 20 * 64 * 64
    assert history_chunk_layers(15, 20, 64 * 64, math.inf) == 15
    assert history_chunk_layers(15, 20, 64 * 64, 15 * layer) == 15
    assert history_chunk_layers(15, 20, 64 * 64, 4 * layer) == 4       # 4, 4, 4, 3
    assert history_chunk_layers(15, 20, 64 * 64, 7 * layer) == 5       # 3 chunks of 5
    assert history_chunk_layers(15, 20, 64 * 64, 0.5 * layer) == 1     # never less than one
    assert history_chunk_layers(1, 20, 64 * 64, 0.0) == 1


def test_contact_parallel_resolves_auto_by_window_size_and_refuses_other_words(monkeypatch):
    monkeypatch.delenv("MICROPIT_CONTACT_PARALLEL", raising=False)
    big = cycle_module.STEPS_MAX_CELLS
    assert cycle_module.contact_parallel(64 * 64) == "steps"
    assert cycle_module.contact_parallel(big) == "steps"
    assert cycle_module.contact_parallel(big + 1) == "slabs"
    assert cycle_module.contact_parallel(64 * 64, "slabs") == "slabs"
    assert cycle_module.contact_parallel(4 * big, "steps") == "steps"
    monkeypatch.setenv("MICROPIT_CONTACT_PARALLEL", "slabs")
    assert cycle_module.contact_parallel(64 * 64) == "slabs"
    assert cycle_module.contact_parallel(64 * 64, "auto") == "steps"   # the argument wins
    monkeypatch.setenv("MICROPIT_CONTACT_PARALLEL", "step")
    with pytest.raises(MicropitError, match=r"MICROPIT_CONTACT_PARALLEL='step'.*auto, steps"):
        cycle_module.contact_parallel(64 * 64)


@pytest.mark.parametrize("counting", ["sliding", "rainflow"])
def test_streamed_stresses_equal_the_whole_history_bitwise(tmp_path, counting, monkeypatch):
    """evaluate streams the stress history through depth in chunks of layers (Dang Van and the
    rainflow counting per chunk): τ_DV and the damage rates equal those of the whole-depth
    history stacked from :meth:`PositionCycle.stresses` bit for bit, for any chunk size
    (here 5 layers in chunks of 2, 2, 1, and all in one)."""
    extra = SMALL.replace("layers = 4", "layers = 5") + f'\n[fatigue]\ncounting = "{counting}"\n'
    cyc = PositionCycle(contact_study(load_scene(gear_scene(tmp_path, extra=extra))), 3)
    fields, p = [], None
    for j in range(cyc.steps):
        fields.append(cyc.solve_step(j, p))
        p = fields[-1].pressure
    rainflow = counting == "rainflow"
    sn = cyc.woehler
    m, points = cyc.steps, 32 * 32
    for body in (1, 2):
        hist = np.stack([cyc.stresses(f, body) for f in fields])
        dv = dang_van(hist, alpha=cyc.alpha_dv, keep_series=rainflow)
        for budget, size in ((math.inf, 5), (2.5 * 48 * m * points, 2), (1.0, 1)):
            cyc.stress_chunk_bytes = budget
            assert cyc.chunk_layers() == size
            tau, rate, low = cyc._streamed_dang_van(fields, body, rainflow)
            assert np.array_equal(tau, dv.tau_dv)
            if rainflow:
                series = dv.series.reshape(m, -1)
                assert np.array_equal(rate.ravel(), rainflow_damage(series, sn.damage))
                assert np.array_equal(low.ravel(), rainflow_damage(series, sn.low_damage))
            else:
                assert rate is None and low is None
        # the history of a chunk is the whole one's on those layers
        spectra = [cyc.traction_spectra(f, body) for f in fields]
        macro = [cyc.macro_stress(f, body) for f in fields]
        assert np.array_equal(cyc.stress_history(spectra, macro, body, slice(1, 3)),
                              hist[:, :, 1:3])
    # Dang Van gets the whole history's batches of points, also when they straddle chunks
    # (batches of 700 points against layers of 1024, one or two layers per chunk)
    monkeypatch.setattr(cycle_module, "DV_CHUNK", 700)
    hist = np.stack([cyc.stresses(f, 1) for f in fields])
    dv = dang_van(hist, alpha=cyc.alpha_dv, chunk=700)
    for budget in (1.0, 2.5 * 48 * m * points):
        cyc.stress_chunk_bytes = budget
        assert np.array_equal(cyc._streamed_dang_van(fields, 1, False)[0], dv.tau_dv)
    monkeypatch.undo()
    # and the whole cycle: one chunk against one layer at a time
    cyc.stress_chunk_bytes = math.inf
    a = cyc.evaluate(cyc.surfaces)
    cyc.stress_chunk_bytes = 1.0
    b = cyc.evaluate(cyc.surfaces)
    for x, y in zip(a.bodies, b.bodies, strict=True):
        assert np.array_equal(x.tau_rough, y.tau_rough)
        assert np.array_equal(x.damage_rate, y.damage_rate)
        assert np.array_equal(x.damage_low, y.damage_low)


def _micropit(*args):
    return subprocess.run([sys.executable, "-m", "micropit_hpc", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=240)


@pytest.mark.slow
def test_snapshot_command_writes_hdf5_and_maps(tmp_path):
    h5py = pytest.importorskip("h5py")
    out = _micropit("snapshot", str(gear_scene(tmp_path)), "--position", "3", "--step", "2",
                    "--out", str(tmp_path / "snap"))
    assert out.returncode == 0, out.stderr
    assert "wrote" in out.stdout and "solid-load fraction" in out.stdout
    with h5py.File(tmp_path / "snap" / "snapshot.h5", "r") as f:
        for name in ("pressure", "clearance", "solid_contact", "traction_body1",
                     "traction_body2", "stress_body1", "stress_body2", "z"):
            assert name in f
        assert f["stress_body1"].shape == (6, 4, 32, 32)
        assert f["stress_body1"].attrs["components"] == "xx,yy,zz,yz,xz,xy"
        assert f.attrs["level"] == "mixed" and f.attrs["step"] == 1
        assert f["pressure"][()].mean() == pytest.approx(f.attrs["p_mean_Pa"], rel=1e-10)
    png = (tmp_path / "snap" / "snapshot.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10000
    assert not list((tmp_path / "snap").glob("*.tmp*"))


@pytest.mark.slow
@pytest.mark.parametrize("args,message", [
    (("--position", "12"), "positions 1 to 11"),
    (("--step", "9"), "steps 1 to 4"),
    (("--step", "0"), "positive whole number"),
])
def test_snapshot_errors_are_one_line(tmp_path, args, message):
    out = _micropit("snapshot", str(gear_scene(tmp_path)), *args, "--out", str(tmp_path / "s"))
    assert out.returncode == 2 and message in out.stderr
    assert "Traceback" not in out.stderr


def test_reference_width_of_a_disc_rig():
    study = contact_study(load_scene(SCENES / "paper_mpr.toml"))
    assert reference_half_width(study) == pytest.approx(study.conditions[0].b)
    assert math.isfinite(study.conditions[0].b)


def test_measured_surface_from_a_scene(tmp_path):
    """kind = "file": read, detrended, periodised, resampled to the window; a missing file and
    an R_q that disagrees with the body's are clear errors naming the key."""
    from micropit_hpc.spectral import Grid
    from micropit_hpc.surfaces import gaussian_surface
    from micropit_hpc.surfaces.bodies import body_surface

    g = Grid(64, 64, 8e-4, 8e-4)
    z = gaussian_surface(g, 2.892e-6, 30e-6, 300e-6, seed=5).heights
    np.save(tmp_path / "flank.npy", z)
    surf = ('\n[body1.surface]\nkind = "file"\nfile = "flank.npy"\nspacing_um = [12.5, 12.5]\n'
            'periodise = "none"\ndetrend = "mean"\n')
    window = SMALL.replace("n = 32", "n = 64\nlength_x_um = 800.0\nlength_y_um = 800.0")
    own = '[body1.surface]\nacf = "exponential"\ncorr_x_um = 30.0\ncorr_y_um = 150.0\n'
    assert own in (SCENES / "gear_z23.toml").read_text()
    path = gear_scene(tmp_path, extra=window + surf, drop=(own,))
    study = contact_study(load_scene(path))
    cyc = PositionCycle(study, 3)
    topo = body_surface(study.scene, 1, cyc.grid)
    assert "flank.npy" in topo.provenance
    assert np.abs(topo.heights - z).max() < 1e-12 * z.std()    # same grid: the map itself
    missing = gear_scene(tmp_path, extra=window + surf.replace("flank.npy", "nope.npy"),
                     drop=(own,), name="missing")
    with pytest.raises(SceneError, match=r"body1\.surface: .*nope\.npy.*not found"):
        PositionCycle(contact_study(load_scene(missing)), 3)
    np.save(tmp_path / "flank.npy", 3 * z)
    with pytest.raises(SceneError, match=r"body1\.Rq_um = 2\.892.*rescale = true"):
        PositionCycle(contact_study(load_scene(path)), 3)


def test_every_surface_kind_and_contact_level_has_its_maker():
    """The tables that choose a body's surface maker and a step's contact solver cover every
    surface kind a scene may name and every level a position may get."""
    from micropit_hpc.plan import LEVELS
    from micropit_hpc.scene import SURFACE_KINDS
    from micropit_hpc.surfaces.bodies import SURFACE_MAKERS

    assert set(SURFACE_MAKERS) == set(SURFACE_KINDS)
    assert set(PositionCycle._CONTACT) == set(LEVELS)


def test_a_warm_start_that_stalls_is_retried_cold(monkeypatch):
    """A contact solve that fails from its warm start (the last evaluation's solution, on other
    surfaces) is solved once more from cold, and the warm start becomes the cold solution's; a
    cold failure stands."""
    from micropit_hpc.lubrication.dry import ContactError

    study = contact_study(_step_scene(steps=3))
    cyc = PositionCycle(study, 2)
    real = PositionCycle._CONTACT[cyc.level]
    calls = []

    def stalls_when_warm(self, r_now, p_mean, t, p_init, warm, free=None):
        calls.append(bool(warm))
        if warm:
            raise ContactError("stalled")
        return real(self, r_now, p_mean, t, p_init, warm, free)

    monkeypatch.setitem(PositionCycle._CONTACT, cyc.level, stalls_when_warm)
    warm = {}
    first = cyc.solve_step(1, None, warm)
    assert calls == [False] and warm
    again = cyc.solve_step(1, None, warm)
    assert calls == [False, True, False] and warm
    np.testing.assert_array_equal(again.pressure, first.pressure)

    def never(self, r_now, p_mean, t, p_init, warm, free=None):
        raise ContactError("no solution")

    monkeypatch.setitem(PositionCycle._CONTACT, cyc.level, never)
    with pytest.raises(ContactError, match="no solution"):
        cyc.solve_step(1)


def test_the_history_buffer_is_one_array_reused_and_grown(monkeypatch):
    """The stress history's chunks of every evaluation write into one array per process
    (:func:`micropit_hpc.cycle.history_buffer`): the same memory again for a size it holds,
    a larger array (the old one dropped) for a larger size, and always exactly ``size``
    elements."""
    monkeypatch.setattr(cycle_module, "_HISTORY_BUFFER", [])
    a = cycle_module.history_buffer(1000)
    assert a.size == 1000 and a.dtype == np.float64
    b = cycle_module.history_buffer(600)
    assert b.size == 600 and np.shares_memory(a, b)
    c = cycle_module.history_buffer(5000)
    assert c.size == 5000 and not np.shares_memory(a, c)
    assert len(cycle_module._HISTORY_BUFFER) == 1
    assert np.shares_memory(cycle_module.history_buffer(1000), c)
