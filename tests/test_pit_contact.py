"""How micropits and the flow balance enter the contact of the next cycle.

* ``life.pit_contact = "unloaded"`` (default): pitted columns carry no pressure and no traction,
  the mean pressure is restored on the rest, and the pit moves with its surface;
* ``"open"``: the contact solve itself holds the pitted columns at zero pressure;
* the flow balance takes the smallest root φ of mean clearance = c_ρ h̄ (the balance is not
  monotone in φ with ``fluid_share = "scaled"``; the earlier search stopped at φ = 1 with the
  clearance twice the film on this MPR-like contact).
"""

import numpy as np
import pytest
from helpers import tiny_doc

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.lubrication import rheology
from micropit_hpc.scene import scene_from_dict


@pytest.fixture(scope="module")
def cycle():
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 32
    return PositionCycle(contact_study(scene_from_dict(doc, "t.toml")), 1)


@pytest.mark.parametrize("step", [3, 4])
def test_the_flow_balance_takes_the_smallest_root(cycle, step):
    cycle.set_surfaces(cycle.surfaces)
    f = cycle.solve_step(step)
    target = rheology.density_correction(f.phi * f.p_mean) * cycle.cond.hc
    assert 0.0 < f.phi < 0.5
    assert np.maximum(f.clearance, 0).mean() == pytest.approx(target, rel=1e-3)
    assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-12)


def test_pits_carry_no_load_and_move_with_their_surface(cycle):
    g = cycle.grid
    pits1 = np.zeros(g.shape, bool)
    pits1[5:8, 10:14] = True
    pits2 = np.zeros(g.shape, bool)
    pits2[20, 3] = True
    cycle.set_surfaces(cycle.surfaces, pits=(pits1, pits2))
    try:
        for step in (1, 4, 6):
            f = cycle.solve_step(step)
            shift1 = round(cycle.slip(1, f.t) / g.dx)
            shift2 = round(cycle.slip(2, f.t) / g.dx)
            mask = np.roll(pits1, shift1, axis=0) | np.roll(pits2, shift2, axis=0)
            assert shift1 != shift2 or step == 1
            assert np.all(f.pressure[mask] == 0.0)
            assert np.all(f.traction1[mask] == 0.0) and not f.solid[mask].any()
            assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-12)   # load balance
            assert f.pressure.max() <= cycle.p_lim
    finally:
        cycle.set_surfaces(cycle.surfaces)


def test_the_load_handed_from_the_pits_to_the_film_is_reported(cycle):
    """The solve sees the surface around the pits, so the pressure it put on the pitted
    columns is that of the same step without pits; its share of the load is what the
    unloading hands to the film (StepFields.pit_load), and the load-cycle evaluation weighs
    the steps' shares like φ."""
    g = cycle.grid
    cycle.set_surfaces(cycle.surfaces)
    free = cycle.solve_step(4)
    top = free.pressure >= np.quantile(free.pressure, 0.95)   # the most loaded 5 % of columns
    assert top.any() and not top.all()
    shift = round(cycle.slip(1, free.t) / g.dx)
    cycle.set_surfaces(cycle.surfaces, pits=(np.roll(top, -shift, axis=0), np.zeros_like(top)))
    try:
        f = cycle.solve_step(4)
        expected = free.pressure[top].sum() / free.pressure.sum()
        assert 0.1 < expected < 1.0
        # the same solve (cold start, same surfaces): its pressures to the solver's tolerance
        assert f.pit_load == pytest.approx(expected, rel=1e-6)
        assert np.all(f.pressure[top] == 0.0)
    finally:
        cycle.set_surfaces(cycle.surfaces)
    assert free.pit_load == 0.0


def test_a_mostly_pitted_window_still_carries_the_load(cycle):
    """When the intact columns cannot carry p̄ below p_lim, they carry p_lim and the pit floors
    the rest: the load never vanishes (it did when the pits of both bodies covered the
    window)."""
    g = cycle.grid
    for frac in (0.9, 1.0):
        pits = np.zeros(g.nx * g.ny, bool)
        pits[: int(frac * g.nx * g.ny)] = True
        pits = pits.reshape(g.shape)
        cycle.set_surfaces(cycle.surfaces, pits=(pits, pits))
        try:
            f = cycle.solve_step(4)
            assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-12)
            assert 0.0 <= f.pressure.min() and f.pressure.max() <= cycle.p_lim
        finally:
            cycle.set_surfaces(cycle.surfaces)


def test_a_pitted_column_wears_down_with_the_surface_around_it():
    """Unloaded pits: a pitted column no longer wears, so the contact sees it at its pre-pit
    height lowered by the wear of the intact columns around it; otherwise it would stand up as
    a spike once they have worn. Without wear it is the pre-pit surface exactly."""
    from micropit_hpc.life import BodyState, _around_pits
    rng = np.random.default_rng(4)
    h0 = rng.normal(0.0, 0.2e-6, (32, 32))
    pitted = np.zeros((32, 32), bool)
    pitted[8, 4] = pitted[24, 9] = pitted[24, 10] = True
    h0[8, 4] = 0.5e-6                     # a high point that pitted early ...
    depth = np.where(pitted, 2e-6, 0.0)
    unworn = BodyState(heights=h0 - depth, damage=np.zeros((2, 32, 32)), pitted=pitted,
                       wear=np.zeros((32, 32)), pit_depth=depth, rq0=0.2e-6)
    np.testing.assert_allclose(_around_pits(unworn), h0, rtol=0, atol=1e-18)
    # ... then the intact surface wore away, a micron on one half and 0.2 µm on the other
    wear = np.where(pitted, 0.0, np.where(np.arange(32)[:, None] < 16, 1e-6, 0.2e-6))
    bs = BodyState(heights=h0 - wear - depth, damage=np.zeros((2, 32, 32)), pitted=pitted,
                   wear=wear, pit_depth=depth, rq0=0.2e-6)
    top = _around_pits(bs)
    np.testing.assert_array_equal(top[~pitted], bs.heights[~pitted])
    # each pitted column stands above (or below) its worn surroundings as it stood before
    # (8 cells from the step in wear: the 2-cell Gaussian reaches across it by e^-8)
    for i, j, w in ((8, 4, 1e-6), (24, 9, 0.2e-6), (24, 10, 0.2e-6)):
        assert top[i, j] == pytest.approx(h0[i, j] - w, abs=1e-9)


def test_the_contact_sees_the_surface_around_unloaded_pits_or_the_pits_themselves():
    """life.contact_surfaces: ``unloaded`` gives the surface around the pits and each body's
    pits (which then carry no load in PositionCycle.evaluate); ``geometric`` the pitted heights
    as they are and no unloaded columns."""
    from micropit_hpc.life import BodyState, LifeState, _around_pits, contact_surfaces
    from micropit_hpc.spectral import Grid

    g = Grid(16, 8, 16e-6, 8e-6)
    rng = np.random.default_rng(5)
    bodies = []
    for _ in range(2):
        pitted = rng.uniform(size=g.shape) < 0.1
        depth = np.where(pitted, 1e-6, 0.0)
        wear = np.where(pitted, 0.0, rng.uniform(0, 1e-7, g.shape))
        h = rng.normal(0.0, 0.2e-6, g.shape) - depth - wear
        bodies.append(BodyState(heights=h, damage=np.zeros((2, *g.shape)), pitted=pitted,
                                wear=wear, pit_depth=depth, rq0=0.2e-6))
    state = LifeState(bodies=tuple(bodies))
    tops, pits = contact_surfaces(state, g, "unloaded")
    for top, mask, bs in zip(tops, pits, state.bodies, strict=True):
        np.testing.assert_array_equal(top.heights, _around_pits(bs))
        assert mask is bs.pitted and (top.dx, top.dy) == (g.dx, g.dy)
    tops, pits = contact_surfaces(state, g, "geometric")
    assert pits is None
    for top, bs in zip(tops, state.bodies, strict=True):
        np.testing.assert_array_equal(top.heights, bs.heights)



def _tiny_cycle(pit_contact, model="auto"):
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 32
    doc.setdefault("life", {})["pit_contact"] = pit_contact
    doc.setdefault("lubrication", {})["model"] = model
    return PositionCycle(contact_study(scene_from_dict(doc, "t.toml")), 1)


@pytest.mark.parametrize("model", ["dry", "auto"])
def test_every_point_the_solids_load_is_in_solid_contact(model, monkeypatch):
    """With h_min = 0 a step's solid mask (boundary friction) holds every point where the dry
    solve (of the dry level, or of the mixed model's lubricated clearance) carries pressure,
    whatever the sign of the solve's residual there, and out of its contact only points whose
    gap is 0 to the solve's accuracy."""
    from micropit_hpc import cycle as cycle_module
    from micropit_hpc.lubrication import dry, mixed

    last = []

    def kept(*args, **kwargs):
        sol = dry.solve_dry_contact(*args, **kwargs)
        last.append(sol)
        return sol

    monkeypatch.setattr(mixed, "solve_dry_contact", kept)
    monkeypatch.setattr(cycle_module, "solve_dry_contact", kept)
    c = _tiny_cycle("unloaded", model)
    assert c.scene.lubrication.h_min == 0.0
    f = c.solve_step(4)
    sol = last[-1]
    contact = sol.pressure > 0
    assert f.level == ("dry" if model == "dry" else "mixed") and contact.any()
    assert np.all(f.solid[contact])
    assert np.all(np.abs(sol.gap[f.solid & ~contact]) <= sol.gap_accuracy)


@pytest.mark.parametrize("model", ["dry", "auto"])
def test_open_pits_are_held_free_inside_the_solve(model):
    """``life.pit_contact = "open"``, the most loaded 5 % of the columns pitted: the contact
    solve itself holds them at p = 0, so the load settles on the intact columns, and the load
    balance over the window holds. Dry: the solids touch on more intact columns than before,
    and nothing is left on the pits to hand on (StepFields.pit_load = 0, where "unloaded"
    hands on the load its solve put there). Mixed (φ < 1): the flow balance holds over the
    intact columns (φ falls, 0.155 → 0.141 here, so the solids may touch on fewer of them);
    the film's pressure over the pits (step 4) is still handed on as before."""
    cycles = {mode: _tiny_cycle(mode, model) for mode in ("open", "unloaded")}
    oc = cycles["open"]
    g = oc.grid
    plain = oc.solve_step(4)
    top = plain.pressure >= np.quantile(plain.pressure, 0.95)
    shift = round(oc.slip(1, plain.t) / g.dx)
    pits = (np.roll(top, -shift, axis=0), np.zeros_like(top))
    out = {}
    for mode, c in cycles.items():
        c.set_surfaces(c.surfaces, pits=pits)
        out[mode] = c.solve_step(4)
    f, unloaded = out["open"], out["unloaded"]
    assert np.all(f.pressure[top] == 0.0) and not f.solid[top].any()
    assert f.pressure.mean() == pytest.approx(f.p_mean, rel=1e-12)
    assert f.pressure[~top].sum() > plain.pressure[~top].sum()
    assert unloaded.pit_load > 0.1
    if model == "dry":
        assert np.count_nonzero(f.solid & ~top) > np.count_nonzero(plain.solid & ~top)
        assert f.level == "dry" and f.pit_load == 0.0
    else:
        assert f.level == "mixed" and 0.0 < f.phi < 1.0
        target = rheology.density_correction(f.phi * f.p_mean) * oc.cond.hc
        assert np.maximum(f.clearance[~top], 0).mean() == pytest.approx(target, rel=1e-3)
