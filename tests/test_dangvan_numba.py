"""The compiled Dang Van kernel (micropit_hpc/fatigue/_dangvan_numba.py) against the NumPy
reference, and the fallback to NumPy where Numba is missing (docs/performance.md, "Compiled
Dang Van")."""

import sys

import numpy as np
import pytest
from helpers import tiny_doc

import micropit_hpc.fatigue
from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.fatigue import dangvan
from micropit_hpc.fatigue.dangvan import ALPHA_DV, dang_van
from micropit_hpc.scene import scene_from_dict

RTOL = 1e-10        # the agreement asked of the compiled kernel, relative (τ_DV and series)


def assert_same(h, **kw):
    """Both kernels on history h: τ_DV and the radius to RTOL relative, the series to RTOL
    relative to each point's largest |series|."""
    ref = dang_van(h, kernel="numpy", keep_series=True, **kw)
    new = dang_van(h, kernel="numba", keep_series=True, **kw)
    assert new.tau_dv.shape == ref.tau_dv.shape and new.series.shape == ref.series.shape
    scale = np.maximum(np.abs(ref.tau_dv), 1e-300)
    assert np.all(np.abs(new.tau_dv - ref.tau_dv) <= RTOL * scale)
    m = h.shape[0]
    s_ref, s_new = ref.series.reshape(m, -1), new.series.reshape(m, -1)
    s_scale = np.maximum(np.abs(s_ref).max(axis=0), 1e-300)
    assert np.all(np.abs(s_new - s_ref).max(axis=0) <= RTOL * s_scale)
    assert np.all(np.abs(new.radius - ref.radius) <= RTOL * np.abs(ref.radius).max(initial=0)
                  + 1e-300)
    # without the series, the same τ_DV
    plain = dang_van(h, kernel="numba", **kw)
    assert plain.series is None and np.array_equal(plain.tau_dv, new.tau_dv)
    return ref, new


needs_numba = pytest.mark.skipif(dangvan.numba_kernel() is None, reason="Numba not installed")


@needs_numba
@pytest.mark.parametrize("m", [1, 2, 3, 6, 7, 8, 20, 72])
def test_random_clouds(m):
    rng = np.random.default_rng(10 + m)
    n = 3000
    h = rng.normal(size=(m, 6, n)) * rng.uniform(1e6, 1e9, size=(1, 1, n))
    h += rng.normal(size=(1, 6, n)) * 3e8           # mean stresses
    assert_same(h)


@needs_numba
def test_random_clouds_in_flats():
    """Paths in lower-dimensional flats of the deviator space (σ_yz = σ_xz = 0 at the surface;
    uniaxial plus shear), where the supports are affinely dependent."""
    rng = np.random.default_rng(11)
    h = rng.normal(size=(20, 6, 4000)) * 1e8
    h[:, 3:5, :2000] = 0.0
    h[:, 1:5, 2000:] = 0.0
    assert_same(h)


@needs_numba
@pytest.mark.parametrize("sa, ta", [(300e6, 200e6), (200e6, 300e6), (400e6, 50e6)])
def test_closed_form_path_of_desimone(sa, ta):
    m = 72
    w = 2 * np.pi * (np.arange(m) + 0.5) / m
    h = np.zeros((m, 6, 1))
    h[:, 0, 0] = sa * (np.cos(w) - 1)
    h[:, 5, 0] = ta * np.sin(w)
    _, new = assert_same(h)
    exact = (0.5 * np.sqrt(sa**2 * np.cos(w) ** 2 + 4 * ta**2 * np.sin(w) ** 2)
             + ALPHA_DV * sa / 3 * (np.cos(w) - 1))
    assert new.tau_dv[0] == pytest.approx(exact.max(), rel=1e-12)


@needs_numba
def test_proportional_paths():
    rng = np.random.default_rng(12)
    n = 500
    mean = rng.normal(size=(1, 6, n)) * 1e8
    amp = rng.normal(size=(1, 6, n)) * 1e8
    a = np.sin(np.linspace(0, 2 * np.pi, 41))[:, None, None] * rng.uniform(0.1, 1, (1, 1, n))
    assert_same(mean + a * amp)
    assert_same(mean + np.abs(a) * amp)                     # pulsating: a ∈ [0, 1]


@needs_numba
def test_degenerate_paths():
    base = np.array([1e8, -2e8, 3e7, 1e7, 0.0, 5e7])
    cases = [
        np.broadcast_to(base[None, :, None], (10, 6, 1)),    # all points equal
        np.zeros((20, 6, 1)),                                # no stress at all
        np.stack([base, -base, base, -base])[:, :, None],    # two points, repeated
        np.stack([base, 2 * base])[:, :, None],              # two points
        (np.linspace(-1, 3, 9)[:, None] * base)[:, :, None],  # collinear, through zero
        (base + np.linspace(0, 1, 9)[:, None] * np.roll(base, 2))[:, :, None],  # collinear
        (base + 1e-5 * np.arange(4.0)[:, None] * base)[:, :, None],  # tiny spread, far away
        np.concatenate([np.zeros((15, 6)), np.broadcast_to(base, (5, 6))])[:, :, None],
    ]
    for h in cases:
        ref, new = assert_same(np.ascontiguousarray(h))
    empty = dang_van(np.zeros((5, 6, 0)), kernel="numba", keep_series=True)
    assert empty.tau_dv.shape == (0,) and empty.series.shape == (5, 0)


@needs_numba
def test_point_axes_and_constant_stress():
    h = np.broadcast_to(np.array([1e8, -2e8, 3e7, 1e7, 0, 5e7])[None, :, None, None],
                        (10, 6, 2, 3))
    r = dang_van(h, kernel="numba")
    assert r.tau_dv.shape == (2, 3) and (r.radius == 0.0).all()
    np.testing.assert_allclose(r.tau_dv, ALPHA_DV * (1e8 - 2e8 + 3e7) / 3, rtol=1e-12)


def tiny_disc(slide_roll):
    """The tiny disc scene of tests/test_life.py (32², 6 layers, 8 steps) at one slide-roll."""
    return scene_from_dict(tiny_doc(slide_roll=(slide_roll,)), "tiny.toml")


@needs_numba
@pytest.mark.parametrize("slide_roll", [0.0, 0.3])
def test_real_stress_histories(slide_roll):
    """One load cycle's histories (PositionCycle, both bodies), and its macro (smooth) ones."""
    cyc = PositionCycle(contact_study(tiny_disc(slide_roll)), 1)
    fields, p_prev = [], None
    for j in range(cyc.steps):
        fields.append(cyc.solve_step(j, p_prev))
        p_prev = fields[-1].pressure
    for body in (1, 2):
        h = np.stack([cyc.stresses(f, body) for f in fields])          # (m, 6, Nz, nx, ny)
        assert_same(h, alpha=cyc.alpha_dv)
        assert_same(cyc.macro_history(body, 0.05, 24), alpha=cyc.alpha_dv)


@needs_numba
def test_a_strided_slice_is_read_in_place_with_the_numbers_of_its_copy():
    """The streamed Dang Van (cycle._streamed_dang_van) hands the kernel slices of a layer
    chunk's history, strided in the points, without copying them: the kernel reads them in
    place and gives the contiguous copy's numbers bit for bit (the same arithmetic)."""
    h = np.random.default_rng(29).normal(size=(24, 6, 300)) * 1e8
    part = h[:, :, 37:261]
    assert not part.flags.c_contiguous
    a = dang_van(part, kernel="numba", keep_series=True)
    b = dang_van(np.ascontiguousarray(part), kernel="numba", keep_series=True)
    for x, y in ((a.tau_dv, b.tau_dv), (a.radius, b.radius), (a.series, b.series)):
        assert np.array_equal(x.view(np.uint64), y.view(np.uint64))


@needs_numba
def test_auto_takes_the_compiled_kernel(monkeypatch):
    h = np.random.default_rng(13).normal(size=(20, 6, 50)) * 1e8
    ref = dang_van(h, kernel="numba")

    def refuse(*args, **kwargs):
        raise AssertionError("the NumPy path was taken")

    monkeypatch.setattr(dangvan, "enclosing_ball", refuse)
    assert np.array_equal(dang_van(h).tau_dv, ref.tau_dv)              # DEFAULT_KERNEL
    assert np.array_equal(dang_van(h, kernel="auto").tau_dv, ref.tau_dv)
    monkeypatch.setattr(dangvan, "DEFAULT_KERNEL", "numpy")
    with pytest.raises(AssertionError, match="NumPy path"):
        dang_van(h)


def test_without_numba_the_numpy_path_is_taken(monkeypatch):
    """Numba made unimportable: "auto" runs the NumPy path, "numba" says what is missing."""
    h = np.random.default_rng(14).normal(size=(20, 6, 50)) * 1e8
    expect = dang_van(h, kernel="numpy", keep_series=True)
    monkeypatch.setitem(sys.modules, "numba", None)                    # import numba fails
    monkeypatch.delitem(sys.modules, "micropit_hpc.fatigue._dangvan_numba", raising=False)
    monkeypatch.delattr(micropit_hpc.fatigue, "_dangvan_numba", raising=False)
    monkeypatch.setattr(dangvan, "_numba_module", None)                # forget the last import
    assert dangvan.numba_kernel() is None
    calls = []
    ball = dangvan.enclosing_ball
    monkeypatch.setattr(dangvan, "enclosing_ball", lambda *a, **k: calls.append(1) or ball(*a, **k))
    got = dang_van(h, keep_series=True)
    assert calls and np.array_equal(got.tau_dv, expect.tau_dv)
    assert np.array_equal(got.series, expect.series)
    with pytest.raises(ImportError, match="needs Numba"):
        dang_van(h, kernel="numba")


def test_kernel_name_checked():
    with pytest.raises(ValueError, match="kernel must be one of"):
        dang_van(np.zeros((5, 6, 2)), kernel="fortran")


def near_axisymmetric(delta, n=200, seed=15):
    """Voigt stresses of n rotated tensors diag(2, −1 + δ, −1 − δ)·1e8 (and their negatives:
    Lode angle near 0 and π/3); the Tresca shear is exactly (3 + δ)/2·1e8."""
    rng = np.random.default_rng(seed)
    q, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    s = np.einsum("nij,j,nkj->nik", q, np.array([2.0, -1.0 + delta, -1.0 - delta]) * 1e8, q)
    s[n // 2:] *= -1.0
    voigt = np.stack([s[:, 0, 0], s[:, 1, 1], s[:, 2, 2], s[:, 1, 2], s[:, 0, 2], s[:, 0, 1]])
    return voigt, (3.0 + delta) / 2 * 1e8


@pytest.mark.parametrize("delta", [1e-3, 1e-6, 1e-9, 1e-12, 0.0])
def test_shear_where_two_principal_values_nearly_coincide(delta):
    """Near Lode angle 0 or π/3 the angle from cos 3θ keeps half the digits; the eigenvalue
    branch (LODE_EDGE) keeps the Tresca shear to round-off, in both kernels."""
    voigt, exact = near_axisymmetric(delta)
    tau = dangvan.mesoscopic_shear(dangvan.deviator_vectors(voigt))
    np.testing.assert_allclose(tau, exact, rtol=1e-13)
    if dangvan.numba_kernel() is not None:
        from micropit_hpc.fatigue._dangvan_numba import _mesoscopic_shear

        v = dangvan.deviator_vectors(voigt)
        got = np.array([_mesoscopic_shear(*v[:, k]) for k in range(v.shape[1])])
        np.testing.assert_allclose(got, exact, rtol=1e-13)


@needs_numba
def test_points_the_compiled_kernel_leaves_unconverged_go_to_the_reference():
    """A point set the compiled kernel does not converge within its iterations is redone on
    the NumPy path (met at 512², one point in 5 M). With no iteration allowed, the kernel
    leaves all but the two-point balls unconverged: those are the reference's exactly, the rest
    agree to round-off."""
    rng = np.random.default_rng(7)
    h = rng.normal(size=(12, 6, 40)) * 1e8
    flat = np.ascontiguousarray(h.reshape(12, 6, -1))
    kernel = dangvan.numba_kernel()
    tau, rad, iters = np.empty(40), np.empty(40), np.empty(40, dtype=np.int64)
    kernel(flat, ALPHA_DV, 1e-12, 0, False, tau, rad, np.empty((1, 1)), iters)
    stuck = iters < 0
    assert 0 < stuck.sum() < 40
    out = dangvan._dang_van_compiled(kernel, flat, (40,), ALPHA_DV, 1e-12, True, max_iter=0)
    ref = dang_van(h, kernel="numpy", keep_series=True)
    np.testing.assert_array_equal(out.tau_dv[stuck], ref.tau_dv[stuck])
    np.testing.assert_array_equal(out.series[:, stuck], ref.series[:, stuck])
    np.testing.assert_allclose(out.tau_dv, ref.tau_dv, rtol=1e-12)


def _stream(h, pieces, **kw):
    """DangVanStream over h (m, 6, n) fed in pieces of the sizes ``pieces`` (summing to n)."""
    stream = dangvan.DangVanStream(h.shape[0], h.shape[2], **kw)
    lo = 0
    for k in pieces:
        stream.feed(np.ascontiguousarray(h[:, :, lo:lo + k]))
        lo += k
    return stream.result()


@pytest.mark.parametrize("kernel", ["numpy", pytest.param("numba", marks=needs_numba)])
def test_a_stream_of_pieces_gives_one_call_on_the_whole_history(kernel):
    """The streamed stresses' Dang Van (cycle._streamed_dang_van): pieces of any size, batches
    straddling them (the NumPy path's 64-point batches over pieces of 50, 0, 90, 37 and 23
    points), the numbers of one call on the whole history bit for bit, series included."""
    h = np.random.default_rng(31).normal(size=(16, 6, 200)) * 1e8
    whole = dang_van(h, kernel=kernel, chunk=64, keep_series=True)
    for series in (True, False):
        got = _stream(h, (50, 0, 90, 37, 23), batch=64, keep_series=series, kernel=kernel)
        assert np.array_equal(got.tau_dv, whole.tau_dv)
        assert np.array_equal(got.radius, whole.radius)
        assert got.iterations == whole.iterations
        assert (np.array_equal(got.series, whole.series) if series else got.series is None)
    with pytest.raises(ValueError, match="150 of 200 points fed"):
        _stream(h, (50, 100), kernel=kernel)
    with pytest.raises(ValueError, match="250 points fed, 200 expected"):
        dangvan.DangVanStream(16, 200, kernel=kernel).feed(np.zeros((16, 6, 250)))


@needs_numba
def test_a_stream_redoes_the_points_the_kernel_leaves_together_at_the_end():
    """Points the compiled kernel leaves unconverged (here with no iteration allowed: all but
    the two-point balls) are redone on the NumPy path in one call at the end, as one call on
    the whole history does (dangvan._dang_van_compiled): the same numbers bit for bit."""
    h = np.random.default_rng(7).normal(size=(12, 6, 90)) * 1e8
    whole = dangvan._dang_van_compiled(dangvan.numba_kernel(), h, (90,), ALPHA_DV, 1e-12, True,
                                       max_iter=0)
    got = _stream(h, (40, 20, 30), keep_series=True, kernel="numba", max_iter=0)
    assert np.array_equal(got.tau_dv, whole.tau_dv)
    assert np.array_equal(got.series, whole.series)
    assert got.iterations == whole.iterations > 0
