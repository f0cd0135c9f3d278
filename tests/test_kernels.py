"""The compiled stages of the contact iteration (micropit_hpc/lubrication/_dry_numba.py) and
the compiled layer combination of the stresses (micropit_hpc/mechanics/_halfspace_numba.py)
against their NumPy references; the plan-buffer transforms (RealFFT2.convolve,
execute_inverse) against plain NumPy FFTs; the fallback where Numba is missing
(docs/performance.md §10)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from helpers import (
    E_PRIME,
    ROOT,
    assert_rounding_close,
    assert_sum_close,
    rough_gap,
    tiny_doc,
    write_scene,
)

from micropit_hpc import compiled
from micropit_hpc.lubrication import dry
from micropit_hpc.lubrication.dry import (
    ElasticHalfSpaces,
    NumpyStages,
    iteration_stages,
    solve_dry_contact,
)
from micropit_hpc.lubrication.mixed import restore_mean
from micropit_hpc.mechanics import HalfSpaceStress, depth_layers
from micropit_hpc.spectral import Grid, rfft_plan

needs_numba = pytest.mark.skipif(
    compiled.compiled_module("lubrication._dry_numba") is None, reason="Numba not installed")


def stage_inputs(shape=(48, 40), seed=1):
    """Fields like an iteration's: p > 0 on about a third of the points (zeros elsewhere),
    gaps of both signs, a direction that vanishes off the contact."""
    rng = np.random.default_rng(seed)
    p = np.where(rng.random(shape) < 0.35, rng.random(shape) * 1e9, 0.0)
    g0, u, g = rng.normal(size=(3, *shape)) * 1e-6
    t = np.where(p > 0, rng.normal(size=shape) * 1e-6, 0.0)
    allowed = rng.random(shape) < 0.8
    return p, g0, u, g, t, allowed


@needs_numba
def test_compiled_stages_equal_the_numpy_stages():
    """Each stage, same inputs: the fields written equal to a few units of round-off of their
    operands (the compiled ones may fuse a multiply-add), the local sums within the rounding
    bound of a sum added in another order (helpers.sum_bound: n·ε·Σ|x|, set by the data, not
    by the CPU's vector width), the counts exactly."""
    p, g0, u, g, t, allowed = stage_inputs()
    shape = p.shape
    ref, new = NumpyStages(shape), iteration_stages(shape, "numba")
    assert not isinstance(new, NumpyStages)

    def both(name, *args):
        """Run stage ``name`` on copies: (NumPy's result, compiled result, both arg lists)."""
        a = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
        b = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
        return getattr(ref, name)(*a), getattr(new, name)(*b), a, b

    on = p > 0
    # gap: g = g0 + c u; (Σ g, count) on the contact
    c = 0.7
    scale = np.abs(g0) + np.abs(c * u)
    (s_a, n_a), (s_b, n_b), a, b = both("gap", g0, u, c, p, g)
    assert_rounding_close(b[4], a[4], scale, what="gap field")
    assert n_a == n_b == np.count_nonzero(on)
    assert_sum_close(s_b, s_a, scale[on], "gap sum", exact=(g0 + c * u)[on])
    gg = a[4]
    # centre: g −= mean; Σ g² on the contact
    mean = float(s_a / n_a)
    scale = np.abs(gg) + abs(mean)
    ra, rb, a, b = both("centre", gg, p, mean)
    assert_rounding_close(b[0], a[0], scale, what="centre field")
    assert_sum_close(rb, ra, (scale**2)[on], "centre sum")
    gg = a[0]
    # direction: t = g + β t on the contact, 0 elsewhere; also into out
    buf = np.empty(shape)
    for beta in (0.0, 0.37):
        _, _, a, b = both("direction", gg, p, t, beta, buf)
        scale = np.abs(gg) + np.abs(beta * t)
        for i in (2, 4):
            assert_rounding_close(b[i], a[i], scale, what=f"direction field {i}")
        assert np.all(b[2][~on] == 0) and np.array_equal(b[2], b[4])
    t_new = a[2]
    # the preconditioned direction: t = z − shift + β t on the contact, 0 elsewhere
    z = u * 1e3
    for beta in (0.0, 0.37):
        shift = 0.21 * float(z[on].mean())
        _, _, a, b = both("direction", z, p, t, beta, buf, shift)
        scale = np.abs(z) + abs(shift) + np.abs(beta * t)
        for i in (2, 4):
            assert_rounding_close(b[i], a[i], scale, what=f"shifted direction field {i}")
        assert np.all(b[2][~on] == 0) and np.array_equal(b[2], b[4])
    # masked: the preconditioner's input, g on the contact and 0 elsewhere: exact
    _, _, a, b = both("masked", gg, p, buf)
    assert np.array_equal(b[2], a[2]) and np.array_equal(a[2], np.where(on, gg, 0.0))
    # preconditioned_sums: (Σ z, Σ g z) on the contact
    ra, rb, _, _ = both("preconditioned_sums", z, gg, p)
    for x, y, terms, what in zip(ra, rb, (z[on], (gg * z)[on]), ("Σ z", "Σ g z"), strict=True):
        assert_sum_close(y, x, np.abs(terms), what, exact=terms)
    # project: (Σ r on the contact, Σ r t, Σ t, Σ g t): sums of the same terms
    ra, rb, _, _ = both("project", u, t_new, gg, p)
    for x, y, terms, what in zip(ra, rb, (u[on], u * t_new, t_new, gg * t_new),
                                 ("Σ r", "Σ r t", "Σ t", "Σ g t"), strict=True):
        assert_sum_close(y, x, np.abs(terms), what, exact=terms)
    # update: p = max(c p − τ t, 0); points at 0 with g < 0 enter at −τ g
    c, tau = 1.3, 2e15
    scale = np.abs(c * p) + np.abs(tau * t_new) + np.abs(tau * gg)
    for restricted in (None, allowed):
        (ne_a, s_a), (ne_b, s_b), a, b = both("update", p, t_new, gg, c, tau, restricted, buf)
        for i in (0, 6):
            assert_rounding_close(b[i], a[i], scale, what=f"update field {i}")
        assert ne_a == ne_b > 0 and b[0].min() >= 0.0 and np.array_equal(b[0], b[6])
        assert_sum_close(s_b, s_a, scale, "update sum")


@needs_numba
@pytest.mark.parametrize("p_lim", [np.inf, 1.6e9])
def test_compiled_solve_equals_the_numpy_solve(p_lim):
    """The whole dry solve with each kernel on a rough 128² gap, elastic and with the cap:
    both converge (their iteration counts may differ: round-off changes where the error
    crosses the tolerance), with pressures within 1e-9 of the peak; both meet the load."""
    g, gap0 = rough_gap(7)
    hs = ElasticHalfSpaces(g, E_PRIME)
    runs = {k: solve_dry_contact(gap0, hs, 1e9, p_lim=p_lim, tol=1e-10, max_iter=5000, kernel=k)
            for k in ("numpy", "numba")}
    a, b = runs["numpy"], runs["numba"]
    assert np.abs(a.pressure - b.pressure).max() <= 1e-9 * a.pressure.max()
    for r in (a, b):
        assert r.pressure.mean() == pytest.approx(1e9, rel=1e-12) and r.error <= 1e-10
        assert r.pressure.max() <= p_lim


def test_convolve_and_inverse_through_the_plan_buffers():
    """RealFFT2.convolve (normalisation in the interleaved transfer, input from the plan's own
    buffer) and execute_inverse equal NumPy's irfft2(rfft2(a)·T) and irfft2 to round-off."""
    rng = np.random.default_rng(3)
    for shape in ((32, 24), (27, 15)):
        plan = rfft_plan(shape)
        a = rng.normal(size=shape)
        T = rng.random((shape[0], shape[1] // 2 + 1))
        expect = np.fft.irfft2(np.fft.rfft2(a) * T, s=shape)
        np.testing.assert_allclose(plan.convolve(plan.interleaved(T), a), expect,
                                   rtol=0, atol=1e-14 * np.abs(expect).max())
        plan.real_input[...] = a
        np.testing.assert_allclose(plan.convolve(plan.interleaved(T)), expect,
                                   rtol=0, atol=1e-14 * np.abs(expect).max())
        batch = rfft_plan(shape, batch=6)
        spec = np.fft.rfft2(rng.normal(size=(6, *shape)))
        batch.spectral_input[...] = spec
        got = batch.execute_inverse() / (shape[0] * shape[1])
        np.testing.assert_allclose(got, np.fft.irfft2(spec, s=shape), rtol=0,
                                   atol=1e-14 * np.abs(got).max())


@pytest.mark.skipif(compiled.compiled_module("mechanics._halfspace_numba") is None,
                    reason="Numba not installed")
@pytest.mark.parametrize("shape", [(64, 48), (27, 15)])
def test_compiled_stresses_equal_the_numpy_stresses(shape):
    """Each layer's spectra formed in one compiled pass and with NumPy: the same stresses to
    1e-14 of the largest, on even (Nyquist lines) and odd grids, with and without q_y, all
    layers and a subset."""
    g = Grid(*shape, 1e-4, 0.8e-4)
    hs = HalfSpaceStress(g, depth_layers(6, 2e-5), 0.3)
    rng = np.random.default_rng(5)
    spectra = [s.copy() for s in hs.spectra(*rng.normal(size=(3, *shape)))]
    for args in (spectra, spectra[:2]):             # with and without q_y
        for layers in (None, [4, 1]):
            ref = hs.stresses(*args, layers=layers, kernel="numpy").copy()
            new = hs.stresses(*args, layers=layers, kernel="numba")
            np.testing.assert_allclose(new, ref, rtol=0, atol=1e-14 * np.abs(ref).max())


def test_without_numba_the_numpy_path_is_taken(monkeypatch):
    """Numba made unimportable: "auto" runs the NumPy stages and combination with the same
    numbers as "numpy"; "numba" says what is missing; a wrong name is refused."""
    g, gap0 = rough_gap(4, n=32)
    hs = ElasticHalfSpaces(g, E_PRIME)
    expect = solve_dry_contact(gap0, hs, 1e9, tol=1e-10, max_iter=5000, kernel="numpy")
    grid = Grid(16, 16, 1e-4, 1e-4)
    stress = HalfSpaceStress(grid, [0.0, 1e-5], 0.3)
    spectra = [s.copy() for s in stress.spectra(*np.random.default_rng(2).normal(size=(3, 16, 16)))]
    s_expect = stress.stresses(*spectra, kernel="numpy").copy()
    field = np.random.default_rng(3).normal(1e9, 2e9, (32, 32))
    m_expect = restore_mean(field, 1.2e9, 4e9, kernel="numpy")
    monkeypatch.setitem(sys.modules, "numba", None)                    # import numba fails
    for name in ("lubrication._dry_numba", "mechanics._halfspace_numba",
                 "lubrication._mixed_numba"):
        monkeypatch.delitem(sys.modules, f"micropit_hpc.{name}", raising=False)
    monkeypatch.setattr(compiled, "_loaded", {})                       # forget the last imports
    assert isinstance(iteration_stages(gap0.shape), NumpyStages)
    got = solve_dry_contact(gap0, hs, 1e9, tol=1e-10, max_iter=5000)
    assert np.array_equal(got.pressure, expect.pressure)
    assert np.array_equal(stress.stresses(*spectra), s_expect)
    assert np.array_equal(restore_mean(field, 1.2e9, 4e9), m_expect)
    with pytest.raises(ImportError, match="needs Numba"):
        restore_mean(field, 1.2e9, 4e9, kernel="numba")
    with pytest.raises(ImportError, match="needs Numba"):
        solve_dry_contact(gap0, hs, 1e9, tol=1e-10, max_iter=5000, kernel="numba")
    with pytest.raises(ImportError, match="needs Numba"):
        stress.stresses(*spectra, kernel="numba")
    with pytest.raises(ValueError, match="kernel must be one of"):
        iteration_stages(gap0.shape, "fortran")
    monkeypatch.setattr(dry, "DEFAULT_KERNEL", "numpy")
    assert isinstance(iteration_stages(gap0.shape), NumpyStages)


COMPILED_MODULES = ("_dry_numba", "_halfspace_numba", "_dangvan_numba")


@needs_numba
@pytest.mark.slow
@pytest.mark.timeout(300)
def test_a_first_run_compiles_every_kernel_from_an_empty_cache_without_hanging(tmp_path):
    """CI and a user's first run start with no Numba cache: a small run must compile every
    kernel it uses and finish. Numba's IR-level ``inline="always"`` on the layer pass once
    made its cold compilation take minutes and a first run time out in CI, hidden here by a
    warm ``__pycache__``. The limit is a hang guard, several times the measured cold run
    (docs/performance.md §10), not a timing claim."""
    scene = write_scene(tmp_path / "t.toml", tiny_doc(slide_roll=(0.3,)))
    cache = tmp_path / "numba-cache"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_"))}
    env.update(NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    run = subprocess.run([sys.executable, "-m", "micropit_hpc", "run", str(scene), "--out",
                          str(tmp_path / "out")], env=env, cwd=tmp_path, capture_output=True,
                         text=True, timeout=240)
    assert run.returncode == 0, run.stderr[-3000:]
    for mod in COMPILED_MODULES:        # each compiled here, not taken from a warm cache
        assert list(cache.rglob(f"{mod}.*.nbi")), (mod, sorted(p.name for p in cache.rglob("*")))
