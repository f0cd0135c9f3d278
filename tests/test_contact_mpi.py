"""The contact solvers distributed over a work item's group (docs/hpc.md §2, issue "Scale" 1).

Run under ``mpirun -n 2 ... -m pytest --with-mpi -m mpi``. The dry solver
(:func:`~micropit_hpc.lubrication.dry.solve_dry_contact`) and the mixed model on the x rows of
a :class:`~micropit_hpc.parallel.slab.Slab` of ``COMM_WORLD`` against the same problem solved
on the whole window by each rank alone: equal to 1e-12 relative, the iteration counts within
one (the mixed model with its φ-scan trials at a loose tolerance: to the solver's tolerance).
Every verdict is allgathered before it is asserted (a failure on one rank must not hang the
other).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from helpers import tiny_doc

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle, contact_split_min_cells
from micropit_hpc.lubrication.dry import ContactError, ElasticHalfSpaces, solve_dry_contact
from micropit_hpc.parallel.slab import Slab
from micropit_hpc.scene import LubricationSpec, scene_from_dict
from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces import gaussian_surface

TOL, MAX_ITER = LubricationSpec().tol, LubricationSpec().max_iter
E_PRIME = 210e9 / (1 - 0.3**2)
RTOL = 1e-12
#: A contact tolerance whose solver error lies below RTOL (see the running-in test).
TIGHT = 1e-13


def agree(comm, ok) -> bool:
    return all(comm.allgather(bool(ok)))


def rel(a, b) -> float:
    """Largest difference relative to the largest magnitude of the reference."""
    scale = float(np.abs(b).max())
    return float(np.abs(a - b).max()) / scale if scale > 0 else float(np.abs(a - b).max())


def _slab(g):
    from mpi4py import MPI

    return Slab(MPI.COMM_WORLD, g, 1)


def _compare_dry(g, gap0, P, p_lim=math.inf, p_init=None, report="", free=None):
    """Distributed against serial on every rank; returns (ok, worst relative difference).
    Both solve to ``TIGHT``, whose error lies below RTOL, so that a stop a few iterations
    apart where round-off moves the residual across the tolerance (the counts may differ)
    still agrees to RTOL (the running-in test below)."""
    slab = _slab(g)
    comm, rows = slab.comm, slab.rows
    serial = solve_dry_contact(gap0, ElasticHalfSpaces(g, E_PRIME), P, p_lim, tol=TIGHT,
                               max_iter=MAX_ITER, p_init=p_init, free=free)
    dist = solve_dry_contact(gap0[rows], ElasticHalfSpaces(g, E_PRIME, slab), P, p_lim,
                             tol=TIGHT, max_iter=MAX_ITER,
                             p_init=None if p_init is None else p_init[rows],
                             free=None if free is None else free[rows])
    p = slab.allgather_rows(dist.pressure)
    gap = slab.allgather_rows(dist.gap)
    worst = max(rel(p, serial.pressure), rel(gap, serial.gap),
                abs(dist.approach - serial.approach) / abs(serial.approach))
    ok = (dist.pressure.shape == (slab.nx_local, g.ny) and worst <= RTOL
          # both converged; the count may move where round-off moves the error across tol
          and dist.error <= TIGHT and abs(dist.iterations - serial.iterations)
          <= 1 + serial.iterations // 10
          # the scalars are the same on every rank
          and len(set(comm.allgather((dist.approach, dist.iterations, dist.error)))) == 1)
    if comm.rank == 0:
        print(f"{report}: {serial.iterations} / {dist.iterations} iterations, "
              f"largest relative difference {worst:.2e}")
    return ok, serial, dist


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("n", [64, 45])
def test_dry_contact_of_a_sphere_on_two_ranks_equals_one_rank(n):
    """Hertz-like smooth gap (odd n: slabs of 23 and 22 rows)."""
    from mpi4py import MPI

    g = Grid(n, n + 3, 2e-3, 2e-3 * (n + 3) / n)
    X, Y = np.meshgrid(g.x, g.y, indexing="ij")
    gap0 = (X**2 + Y**2) / (2 * 0.01)
    ok, serial, _ = _compare_dry(g, gap0, 0.1e9, report=f"sphere {n}")
    ok = ok and serial.area_fraction > 0.01
    assert agree(MPI.COMM_WORLD, ok)


@pytest.mark.mpi(min_size=2)
def test_rough_plastic_dry_contact_and_its_warm_start_on_two_ranks_equal_one_rank():
    """A random rough gap with the cap p_lim active (plastic cells), cold and warm-started."""
    from mpi4py import MPI

    g = Grid(96, 80, 4e-4, 4e-4 * 80 / 96)
    z = gaussian_surface(g, 1e-6, 20e-6, 60e-6, seed=7).heights
    gap0 = z.max() - z
    p_lim = 2.0e9
    ok, serial, _ = _compare_dry(g, gap0, 0.8e9, p_lim, report="rough plastic")
    ok = ok and np.count_nonzero(serial.pressure >= p_lim) > 20
    ok2, _, _ = _compare_dry(g, gap0, 0.88e9, p_lim, p_init=serial.pressure,
                             report="rough plastic, warm")
    assert agree(MPI.COMM_WORLD, ok and ok2)


@pytest.mark.mpi(min_size=2)
def test_the_coarse_to_fine_start_on_two_ranks_equals_one_rank():
    """A 128² rough plastic gap, cold: the distributed solve gathers the gap, runs the coarse
    64² level on every rank alike and goes on over the slabs; equal to the one-rank solve
    (which starts from the same coarse level) to 1e-12, and the start is taken."""
    from mpi4py import MPI

    g = Grid(128, 128, 4e-4, 4e-4)
    z = gaussian_surface(g, 1e-6, 20e-6, 60e-6, seed=11).heights
    ok, serial, dist = _compare_dry(g, z.max() - z, 0.8e9, 2.0e9, report="coarse-to-fine")
    ok = (ok and serial.coarse_iterations > 0
          and dist.coarse_iterations == serial.coarse_iterations
          and np.count_nonzero(serial.pressure >= 2.0e9) > 20)
    assert agree(MPI.COMM_WORLD, ok)


@pytest.mark.mpi(min_size=2)
def test_open_pits_held_free_on_two_ranks_equal_one_rank():
    """Columns held at p = 0 (``life.pit_contact = "open"``) on a 128² rough plastic gap,
    cold (the coarse levels restrict the mask) and warm from a start that loads them."""
    from mpi4py import MPI

    g = Grid(128, 128, 4e-4, 4e-4)
    z = gaussian_surface(g, 1e-6, 20e-6, 60e-6, seed=11).heights
    gap0 = z.max() - z
    first = solve_dry_contact(gap0, ElasticHalfSpaces(g, E_PRIME), 0.8e9, 2.0e9, tol=TOL,
                              max_iter=MAX_ITER)
    free = first.pressure >= np.quantile(first.pressure, 0.97)
    ok, serial, _ = _compare_dry(g, gap0, 0.8e9, 2.0e9, report="open pits", free=free)
    ok2, _, _ = _compare_dry(g, gap0, 0.8e9, 2.0e9, p_init=first.pressure,
                             report="open pits, warm", free=free)
    ok = ok and ok2 and np.all(serial.pressure[free] == 0.0)
    assert agree(MPI.COMM_WORLD, ok)


@pytest.mark.mpi(min_size=2)
def test_a_failing_dry_contact_fails_on_every_rank():
    from mpi4py import MPI

    g = Grid(32, 32, 4e-4, 4e-4)
    z = gaussian_surface(g, 1e-6, 20e-6, 60e-6, seed=7).heights
    slab = _slab(g)
    raised = False
    try:
        solve_dry_contact((z.max() - z)[slab.rows], ElasticHalfSpaces(g, E_PRIME, slab), 1e9,
                          tol=TOL, max_iter=3)
    except ContactError:
        raised = True
    assert agree(MPI.COMM_WORLD, raised)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
@pytest.mark.parametrize("model,scan", [("auto", "tight"), ("auto", "loose"), ("dry", "tight")])
def test_cycle_steps_of_the_tiny_disc_on_two_ranks_equal_one_rank(model, scan, monkeypatch):
    """Every time step of the tiny disc scene (mixed model, and the dry one) with the window
    split over 2 ranks (``--ranks-per-item 2``), three times: the later passes warm-started by
    the earlier ``warm`` dicts, as a life block's evaluations are, the last with unloaded
    pits. Pressure, clearance and φ within 1e-12 relative, the contact sets equal, with every
    dry solve at the scene's tolerance (``scan = "tight"``).

    With the mixed model's default, the φ scan's trials below φ = 1 solved to
    ``mixed.SCAN_TOLERANCE`` (``"loose"``), a round-off difference can move where a loose solve
    stops or a yielded point's release at its loose threshold: the trials' pressures, which
    only start the later solves, then differ at the loose tolerance's level, and the answers,
    each a solve to the scene's tolerance, agree to that tolerance: within 10 × TOL relative
    (measured 7.7e-11; the pressure error of a solve stopped at ε ≤ tol is a few tol at
    these sizes, docs/performance.md §11)."""
    from mpi4py import MPI

    from micropit_hpc.lubrication import mixed

    comm = MPI.COMM_WORLD
    if scan == "tight":
        monkeypatch.setattr(mixed, "SCAN_TOLERANCE", None)
    bound = RTOL if scan == "tight" else 10 * TOL
    monkeypatch.setenv("MICROPIT_CONTACT_SPLIT_MIN_CELLS", "0")      # split even 27²
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 27
    # tight: the scene's tolerance below RTOL (as in the running-in test), so that a solve
    # stopped an iteration apart by round-off still agrees to RTOL
    doc["lubrication"] = {"model": model, **({"tolerance": TIGHT} if scan == "tight" else {})}
    scene = scene_from_dict(doc, "tiny.toml")
    study = contact_study(scene)
    one = PositionCycle(study, 1)
    split = PositionCycle(study, 1, comm=comm, parallel="slabs")
    ok = split.slab.nx_local == (14 if comm.rank == 0 else 13) and split.half_spaces.distributed
    ok = ok and split.level == one.level == ("mixed" if model == "auto" else "dry")
    worst, iters, flips = 0.0, [], 0
    h_min = scene.lubrication.h_min
    # a mixed step adds up the iterations of its ~5–10 dry solves (load-fraction scan and
    # root search), each of which may stop one iteration apart at round-off: measured ±2
    slack = 1 if model == "dry" else 3
    warm1, warm2 = {}, {}
    pits = np.zeros(one.grid.shape, bool), np.zeros(one.grid.shape, bool)
    pits[0][5:9, 3:7] = pits[1][20:22, 10:20] = True
    for sweep in range(3):
        if sweep == 2:      # unloaded pits (life.pit_contact = "unloaded"), whole maps
            for c in (one, split):
                c.set_surfaces(c.surfaces, pits)
        p1 = p2 = None
        for j in range(one.steps):
            a = one.solve_step(j, p1, warm1.setdefault(j, {}))
            b = split.solve_step(j, p2, warm2.setdefault(j, {}))
            p1, p2 = a.pressure, b.pressure
            ok = ok and b.pressure.shape == a.pressure.shape == one.grid.shape
            worst = max(worst, rel(b.pressure, a.pressure), rel(b.clearance, a.clearance),
                        abs(b.phi - a.phi))
            # the contact sets equal; with the loose scan, but for points whose clearance is
            # within the bound of h_min (a difference at the tolerance can flip them)
            edge = np.abs(a.clearance - h_min) <= bound * np.abs(a.clearance).max()
            ok = ok and np.array_equal(b.solid | edge, a.solid | edge)
            flips += int(np.count_nonzero(b.solid != a.solid))
            ok = ok and (scan == "loose" or np.array_equal(b.solid, a.solid))
            ok = ok and abs(b.iterations - a.iterations) <= slack + a.iterations // 10
            iters.append((a.iterations, b.iterations))
            # the whole-window fields are the same on every rank, bit for bit
            mine = (b.pressure, b.clearance, b.traction1)
            ok = ok and all(np.array_equal(x, y) for theirs in comm.allgather(mine)
                            for x, y in zip(mine, theirs, strict=True))
    ok = ok and worst <= bound and any(a > 0 for a, _ in iters)
    if comm.rank == 0:
        print(f"tiny disc ({model}, {scan} scan): iterations {iters}; largest relative "
              f"difference {worst:.2e}; contact-set points that differ {flips}")
    assert agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
@pytest.mark.parametrize("model", ["auto", "dry"])
def test_open_pits_and_the_plastic_running_in_on_two_ranks_equal_one_rank(model, monkeypatch):
    """``life.pit_contact = "open"`` (pits held free inside the distributed dry solves, the
    flow balance summed over the intact columns of each slab) and the plastic running-in
    (``life.running_in``) with the tiny disc's window split over 2 ranks: the steps' fields
    and the run-in heights within 1e-12 relative of one rank's, the same on every rank.

    The contact solves go to ``lubrication.tolerance = 1e-13`` (``TIGHT``), not the default
    1e-8: the ranks' sums round differently from one rank's, and a stopping test of the
    iteration (the inexact phases, the yielded set's release) can then fall the other way and
    stop the solve a few iterations apart. At 1e-8 that happened on an AMD EPYC with AVX-512
    at step 4 of the run-in's first pass (33 against 26 iterations: pressure 3.4e-8, run-in
    heights 2.3e-9 apart), within the solver's accuracy but not the rounding this test checks.
    At 1e-13 a solve's pressure error is a few 1e-13 (docs/performance.md §11), so a stop
    apart moves the answer by less than the 1e-12 bound and the test compares the distributed
    code, not the stopping rule (measured there: 4.7e-15 after 4 passes, the same
    iterations)."""
    from mpi4py import MPI

    from micropit_hpc.life import initial_state
    from micropit_hpc.running_in import run_in

    comm = MPI.COMM_WORLD
    monkeypatch.setenv("MICROPIT_CONTACT_SPLIT_MIN_CELLS", "0")
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 27
    doc["lubrication"] = {"model": model, "tolerance": TIGHT}
    doc["body1"]["hardness_GPa"] = doc["body2"]["hardness_GPa"] = 3.0
    doc["life"].update(pit_contact="open", running_in="plastic", running_in_passes=4)
    scene = scene_from_dict(doc, "tiny.toml")
    study = contact_study(scene)
    one = PositionCycle(study, 1)
    split = PositionCycle(study, 1, comm=comm, parallel="slabs")
    ok = split.half_spaces.distributed
    pits = np.zeros(one.grid.shape, bool), np.zeros(one.grid.shape, bool)
    pits[0][5:9, 3:7] = pits[1][20:22, 10:20] = True
    worst = 0.0
    for c in (one, split):
        c.set_surfaces(c.surfaces, pits)
    for j in range(one.steps):
        a, b = one.solve_step(j), split.solve_step(j)
        worst = max(worst, rel(b.pressure, a.pressure), rel(b.clearance, a.clearance),
                    abs(b.phi - a.phi))
        ok = ok and np.array_equal(b.solid, a.solid)
    states = [initial_state(c) for c in (one, split)]
    for c, st in zip((one, split), states, strict=True):
        c.set_surfaces(c.surfaces)
        run_in(c, st, scene.life)
    for b1, b2 in zip(*(st.bodies for st in states), strict=True):
        worst = max(worst, rel(b2.heights - b2.heights.mean(), b1.heights - b1.heights.mean()))
        ok = ok and all(np.array_equal(b2.heights, h) for h in comm.allgather(b2.heights))
    ok = ok and worst <= RTOL
    if comm.rank == 0:
        print(f"open pits and running-in ({model}): largest relative difference {worst:.2e}")
    assert agree(comm, ok)


@pytest.mark.mpi(min_size=2)
def test_a_small_window_solves_its_contact_on_every_rank_alike_as_one_rank(monkeypatch):
    """Below contact_split_min_cells the group's ranks each solve the whole window: the
    one-rank numbers, bit for bit, and no communication in the solver."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    monkeypatch.delenv("MICROPIT_CONTACT_SPLIT_MIN_CELLS", raising=False)
    doc = tiny_doc(slide_roll=(0.3,))
    doc["lubrication"] = {"model": "dry"}
    study = contact_study(scene_from_dict(doc, "tiny.toml"))
    one = PositionCycle(study, 1)
    split = PositionCycle(study, 1, comm=comm, parallel="slabs")
    ok = split.grid.nx * split.grid.ny < contact_split_min_cells()
    ok = ok and split.slab.comm.size == 2 and not split.half_spaces.distributed
    p1 = p2 = None
    for j in range(one.steps):
        a, b = one.solve_step(j, p1), split.solve_step(j, p2)
        p1, p2 = a.pressure, b.pressure
        ok = ok and a.iterations == b.iterations and all(
            np.array_equal(x, y) for x, y in ((a.pressure, b.pressure),
                                              (a.clearance, b.clearance)))
    assert agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_a_cycle_shares_its_time_steps_over_the_ranks_with_one_ranks_numbers():
    """``contact_parallel = "steps"``: rank r solves its steps (``step_owners``) on the whole
    window, each next to its mirror, and the fields are broadcast: every step's fields equal
    one rank's bit for bit on every rank, in two passes (the second warm-started from the
    first's ``warm`` dicts), each rank solved only its own steps, and a solver error on one
    rank's step is raised on both."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"]["n"] = 27
    study = contact_study(scene_from_dict(doc, "tiny.toml"))
    one = PositionCycle(study, 1)
    shared = PositionCycle(study, 1, comm=comm, parallel="steps")
    ok = shared.contact_parallel == "steps" and not shared.half_spaces.distributed
    ok = ok and shared.level == one.level == "mixed"
    m = one.steps
    owners = shared.step_owners(comm.size)
    mine = sorted(j for j in range(m) if owners[j] == comm.rank)
    warm1, warm2 = {}, {}
    for _ in range(2):
        solved = []
        a = one._contact_steps(warm1, None)
        b = shared._contact_steps(warm2, solved.append)
        ok = ok and solved == [min(m, k * comm.size) for k in range(1, len(mine) + 1)]
        ok = ok and sorted(warm2) == mine
        for x, y in zip(a, b, strict=True):
            ok = ok and x.iterations == y.iterations and x.phi == y.phi
            ok = ok and all(np.array_equal(u, v) for u, v in (
                (x.pressure, y.pressure), (x.clearance, y.clearance),
                (x.traction1, y.traction1), (x.solid, y.solid)))
    # a solve that cannot converge on the steps of rank 1 only: both ranks raise its error
    scene = scene_from_dict(doc, "tiny.toml")
    if comm.rank == 1:      # below the scene's range (10): set past the reader
        scene = replace(scene, lubrication=replace(scene.lubrication, max_iter=2))
    failing = PositionCycle(contact_study(scene), 1, comm=comm, parallel="steps")
    raised = None
    try:
        failing._contact_steps(None, None)
    except ContactError as e:
        raised = str(e)
    ok = ok and raised is not None and raised == comm.bcast(raised, root=1)
    assert agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.timeout(300)
def test_steps_raised_by_the_kinematics_are_shared_over_the_ranks():
    """The steps the kinematic rule chose (docs/model.md §4; the tiny disc at |S| = 0.3 with
    λ_c/22 per step: 33, more than its floor of 3 and odd) are the same on every rank and are
    shared over them like any m, with one rank's numbers on every rank."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    doc = tiny_doc(slide_roll=(0.3,))
    doc["window"] = {"n": 16, "steps": 3, "steps_per_peak_spacing": 22.0}
    study = contact_study(scene_from_dict(doc, "tiny.toml"))
    one = PositionCycle(study, 1)
    shared = PositionCycle(study, 1, comm=comm, parallel="steps")
    ok = one.steps > 3 and shared.steps == one.steps and one.steps % comm.size != 0
    ok = ok and comm.allgather(shared.steps) == [one.steps] * comm.size
    solved = []
    a = one._contact_steps(None, None)
    b = shared._contact_steps(None, solved.append)
    m = one.steps
    count = shared.step_owners(comm.size).count(comm.rank)
    ok = ok and solved == [min(m, k * comm.size) for k in range(1, count + 1)]
    ok = ok and len(b) == one.steps and all(
        np.array_equal(x.pressure, y.pressure) and x.t == y.t for x, y in zip(a, b, strict=True))
    assert agree(comm, ok)


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("h_mean", [1e-12, 0.1e-6])
def test_the_coarse_phi_scan_on_two_ranks_equals_one_rank(h_mean, monkeypatch):
    """The mixed model's φ scan made on the coarsened window (every rank alike, serial) and
    its bracket solved over the slabs: φ, pressure and clearance equal to the one-rank
    solution to 1e-12, where the root is φ = 1 and between two trials (every dry solve at the
    scene's tolerance, here ``TIGHT``: below RTOL, as in the running-in test)."""
    from helpers import mixed_settings, random_pair
    from mpi4py import MPI

    from micropit_hpc.lubrication import mixed
    from micropit_hpc.lubrication.mixed import MixedLubrication
    from micropit_hpc.spectral import rfft_plan

    monkeypatch.setattr(mixed, "SCAN_POINTS", 32)      # 128² → 32² (SCAN_LEVELS 3: two halvings)
    # every dry solve at the scene's tolerance, so that the two agree to round-off (the loose
    # trials' agreement to the tolerance: the tiny disc's test above)
    monkeypatch.setattr(mixed, "SCAN_TOLERANCE", None)
    g, (z1, z2) = random_pair(128)
    fft = rfft_plan(g.shape)
    r = (fft.forward(-z1), fft.forward(-z2))

    def model(slab=None):
        return MixedLubrication(g, geometry="line", load=3e5, R=0.01, b=2e-4, u1=2.3, u2=1.7,
                                h_mean=h_mean, E_prime=E_PRIME,
                                **mixed_settings(0.05, 20e-9, 4.2e9, tol=TIGHT), slab=slab)

    one, split = model(), model(_slab(g))
    a = one.solve(r, r, 1.0e9, 5e-5)
    b = split.solve(r, r, 1.0e9, 5e-5)
    # the same film balances in the same order; the coarse ones bit for bit (every rank
    # solves them alone), those on the window, and the root search's trial fractions, to
    # round-off (summed over the slabs). A balance is a difference of two clearances of
    # order h̄, so its round-off is relative to h̄ as much as to itself (the root's balance,
    # −5.7e-12 m at h̄ = 1e-7 m, differed by 1.0e-20 m: 1.8e-9 of itself, 1e-13 of h̄)
    same = len(split.last_scan) == len(one.last_scan) and all(
        x[1] == y[1] and (x == y if x[1] else abs(x[0] - y[0]) <= RTOL
                          and abs(x[2] - y[2]) <= 1e-9 * abs(y[2]) + RTOL * h_mean)
        for x, y in zip(split.last_scan, one.last_scan, strict=False))
    if MPI.COMM_WORLD.rank == 0:
        print(f"coarse φ scan, h̄ = {h_mean:.2g}: φ {a.phi:.6g} / {b.phi:.6g}; "
              f"{one.last_scan} / {split.last_scan}")
    ok = (one._scan_grid()[0] == 2 and same
          and any(levels for _, levels, _ in one.last_scan)
          and (a.phi == 1.0 if h_mean == 1e-12 else 0.0 < a.phi < 1.0)
          and abs(b.phi - a.phi) <= RTOL and rel(b.pressure, a.pressure) <= RTOL
          and rel(b.clearance, a.clearance) <= RTOL)
    assert agree(MPI.COMM_WORLD, ok)
