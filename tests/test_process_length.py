"""The stresses averaged over the material's process area before the Dang Van criterion
(``fatigue.process_length_um`` = ℓ, docs/life.md "A process length for the criterion"): every
component at every depth of a single-mode load scaled by exp(−k²ℓ²/24), the mean and the macro
field kept, and the surface stresses of a sharp-edged pit in the pressure map converging with
the grid where the pointwise field (ℓ = 0) keeps growing."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from helpers import SCENES

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle, StepFields
from micropit_hpc.errors import MicropitError
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.spectral import Grid, discrete_gaussian

MU = 0.08


def _doc(n: int = 64, layers: int | None = None, ell_um: float | None = None) -> dict:
    """The paper gear's scene as a dict, on an n² window of its physical size, with ``layers``
    depth layers and ``[fatigue] process_length_um = ell_um`` where given."""
    doc = tomllib.loads((SCENES / "paper_gear_z23.toml").read_text())
    doc["window"]["n"] = n
    if layers is not None:
        doc.setdefault("stress", {})["layers"] = layers
    if ell_um is not None:
        doc["fatigue"] = {"process_length_um": ell_um}
    return doc


def _cycle(n: int, ell_um: float | None, layers: int = 5) -> PositionCycle:
    """Position 5 of the paper gear (S = −0.05, p0 1.08 GPa) on an n² window of the scene's
    physical size, ``layers`` depth layers, process length ``ell_um`` (None: the key left
    out)."""
    return PositionCycle(contact_study(scene_from_dict(_doc(n, layers, ell_um), "gear.toml")), 5)


def _fields(cyc: PositionCycle, pressure: np.ndarray) -> StepFields:
    """A step at t = 0 (no slip, so the material frame is the window's) carrying ``pressure``
    with the traction μ p on body 1 and −μ p on body 2."""
    q = MU * pressure
    return StepFields(position=5, step=0, t=0.0, x_c=cyc.centre(0.0),
                      p_mean=float(pressure.mean()), level="dry", pressure=pressure,
                      clearance=np.zeros_like(pressure), solid=np.ones(pressure.shape, bool),
                      friction=np.full(pressure.shape, MU), phi=1.0, iterations=0,
                      traction1=q, traction2=-q)


def _micro(cyc: PositionCycle, f: StepFields, body: int) -> np.ndarray:
    return cyc.stresses(f, body) - cyc.macro_stress(f, body)


@pytest.mark.parametrize("body", [1, 2])
def test_a_single_mode_is_scaled_by_the_gaussian_at_every_depth(body):
    """p = p̄[1 + 0.4 cos(k·x)] (k: 5 and 3 periods over the window) with q = ±μp: with
    ℓ = 10 µm every stress component on every layer is the discrete Gaussian's transfer times
    the pointwise one (the averaging is a convolution in the plane, and the half-space kernels
    commute with it); the macro field is the same, and at the surface σ_zz = −(p̃ − p̄),
    σ_xz = ∓μ(p̃ − p̄) with p̃ the averaged pressure."""
    ell = 10e-6
    pointwise, averaged = _cycle(32, 0.0), _cycle(32, ell * 1e6)
    g = pointwise.grid
    x = np.arange(g.nx)[:, None] / g.nx
    y = np.arange(g.ny)[None, :] / g.ny
    phase = 2 * math.pi * (5 * x + 3 * y)
    p_bar = 1.0e9
    p = p_bar * (1.0 + 0.4 * np.cos(phase))
    kx, ky = 2 * math.pi * 5 / (g.nx * g.dx), 2 * math.pi * 3 / (g.ny * g.dy)
    # the discrete Gaussian of variance ℓ²/12 per axis: exp(−(ℓ²/12Δ²)(1 − cos kΔ)) each
    factor = math.exp(-ell * ell / 12 * ((1 - math.cos(kx * g.dx)) / g.dx ** 2
                                         + (1 - math.cos(ky * g.dy)) / g.dy ** 2))
    assert 0.3 < factor < 0.9                       # a real cut, not round-off
    # near the continuous Gaussian's exp(−|k|²ℓ²/24) for a wave of 6.4 and 10.7 cells
    assert factor == pytest.approx(math.exp(-(kx * kx + ky * ky) * ell * ell / 24), rel=0.06)
    s0 = _micro(pointwise, _fields(pointwise, p), body)
    s1 = _micro(averaged, _fields(averaged, p), body)
    assert np.abs(s0).max() > 0.1 * p_bar
    np.testing.assert_allclose(s1, factor * s0, rtol=0, atol=1e-9 * p_bar)
    np.testing.assert_array_equal(averaged.macro_stress(_fields(averaged, p), body),
                                  pointwise.macro_stress(_fields(pointwise, p), body))
    # at the surface the micro field is that of the averaged maps less their means
    p_avg = p_bar * 0.4 * factor * np.cos(phase)
    sign = 1.0 if body == 1 else -1.0
    np.testing.assert_allclose(-s1[2, 0], p_avg, rtol=0, atol=1e-9 * p_bar)
    np.testing.assert_allclose(-s1[4, 0], sign * MU * p_avg, rtol=0, atol=1e-9 * p_bar)


@pytest.mark.parametrize("cells", [0.5, 0.78, 1.56, 3.0, 8.0])
def test_the_averaging_kernel_is_positive_with_the_squares_second_moment(cells):
    """The kernel of the averaging (the inverse transform of the cycle's transfer) is
    non-negative to round-off at every ℓ/Δx, so the averaged pressure of a non-negative map is
    non-negative (a kernel of the continuous Gaussian's transfer cut at the Nyquist wave has
    lobes down to −2.6 % of its peak at 1.56 cells); it sums to 1 and has the second moment
    ℓ²/12 of an ℓ × ℓ square along each axis; and its transfer tends to exp(−|k|²ℓ²/24) as
    the cell shrinks."""
    ell, n_cells = 5e-6, 128
    g = Grid(nx=n_cells, ny=n_cells, lx=n_cells * ell / cells, ly=n_cells * ell / cells)
    spec = discrete_gaussian(g, ell * ell / 12)
    kernel = np.fft.irfft2(spec, s=(g.nx, g.ny))
    assert kernel.min() > -1e-15 and kernel.sum() == pytest.approx(1.0, abs=1e-12)
    n = np.fft.fftfreq(g.nx, 1.0 / g.nx)
    for axis in (0, 1):
        moment = (kernel.sum(axis=1 - axis) * n ** 2).sum()
        assert moment == pytest.approx(cells ** 2 / 12, rel=1e-9)     # in cells²
    # its exponent is the continuous one's times a factor in [1 − (kΔ)²/12, 1] per axis
    # (1 − cos x = x²/2 − x⁴/24 + …), so it tends to exp(−|k|²ℓ²/24) as kΔ → 0
    kd = np.maximum(np.abs(g.kx) * g.dx, np.abs(g.ky) * g.dy)
    ratio = np.log(spec[1:]) / (-g.kappa[1:] ** 2 * ell * ell / 24)
    assert (ratio <= 1 + 1e-12).all() and (ratio >= 1 - kd[1:] ** 2 / 12 - 1e-12).all()


def test_the_default_length_follows_the_integration():
    """Without the key a scene gets 5 µm in the converged default (``life.integration =
    "adaptive"``) and 0, the paper's pointwise criterion, in its literal numerics (``"paper"``);
    a value given is kept in both, 0 included."""
    for integration, default in (("adaptive", 5.0 * 1e-6), ("paper", 0.0)):   # a file's 5 µm
        for ell_um, want in ((None, default), (0.0, 0.0), (10.0, 10.0 * 1e-6)):   # µm as read
            doc = _doc(ell_um=ell_um)
            doc["life"]["integration"] = integration
            assert scene_from_dict(doc, "gear.toml").fatigue.process_length == want, (
                integration, ell_um)


def test_zero_length_is_the_pointwise_criterion_bit_for_bit():
    """ℓ = 0 applies nothing: the same stresses bit for bit as the literal twin's scene, which
    does not name the key (its default is the pointwise criterion)."""
    doc = _doc(32, 4)
    doc["life"]["integration"] = "paper"
    plain = PositionCycle(contact_study(scene_from_dict(doc, "gear.toml")), 5)
    zero = _cycle(32, 0.0, layers=4)
    assert plain.scene.fatigue.process_length == 0.0 and zero.process_transfer(slice(0, 17)) is None
    assert _cycle(32, None, layers=4).process_transfer(slice(0, 17)) is not None
    f = plain.solve_step(plain.steps // 2)
    for body in (1, 2):
        np.testing.assert_array_equal(zero.stresses(f, body), plain.stresses(f, body))


def _pit_map(cyc: PositionCycle, radius: float) -> np.ndarray:
    """p̄ = 1 GPa everywhere but a disc of the given radius at the window's centre (a pit,
    carrying nothing), the cells whose centres lie inside it."""
    g = cyc.grid
    x = (np.arange(g.nx) - g.nx // 2)[:, None] * g.dx
    y = (np.arange(g.ny) - g.ny // 2)[None, :] * g.dy
    return np.where(x * x + y * y <= radius * radius, 0.0, 1.0e9)


def test_a_pit_edge_converges_with_the_grid_only_over_a_process_area():
    """The friction on the rim of a pit (p and q = μp dropping to zero over a disc of 15 µm
    radius) puts a logarithmic singularity into the surface σ_xx of the pointwise field: its
    largest value grows by about (2μ/π)·p̄·ln 2 per halving of the cell (a uniform tangential
    traction q on a strip of the half-plane gives σ_x(x, 0) = (2q/π) ln|(x − a)/(x + a)| at
    its surface; Johnson, Contact Mechanics, ch. 2), so a pointwise criterion's result at the rim
    follows the cell. Averaged over ℓ = 10 µm the same maps give surface stresses that move
    by a small fraction of that growth per doubling (measured with the discrete Gaussian of
    the averaging: from 32² to 128² 1.18 and 1.19 steps per doubling pointwise, 0.35 and 0.11
    averaged; from 128² to 256² 0.80 and 0.10; the disc's cells, and so the map, differ from
    grid to grid)."""
    radius, p_bar = 15e-6, 1.0e9
    step = 2 * MU / math.pi * p_bar * math.log(2)      # the log law's growth per doubling
    peak = {}
    for ell in (0.0, 10.0):
        for n in (32, 64, 128):
            cyc = _cycle(n, ell, layers=2)
            s = _micro(cyc, _fields(cyc, _pit_map(cyc, radius)), 1)[:, 0]
            peak[ell, n] = float(np.abs(s[0]).max())
    pointwise = [peak[0.0, n] for n in (32, 64, 128)]
    averaged = [peak[10.0, n] for n in (32, 64, 128)]
    assert pointwise[1] - pointwise[0] > 0.5 * step
    assert pointwise[2] - pointwise[1] > 0.5 * step
    assert abs(averaged[2] - averaged[1]) < 0.15 * (pointwise[2] - pointwise[1])
    assert abs(averaged[1] - averaged[0]) < 0.5 * (pointwise[1] - pointwise[0])


def test_a_negative_length_is_refused_with_its_key():
    with pytest.raises(MicropitError, match="process_length_um"):
        scene_from_dict(_doc(ell_um=-1.0), "gear.toml")


def test_a_process_length_the_grid_does_not_resolve_is_warned_about():
    """ℓ = 4 µm on the paper gear's 64² window (3.2 µm cells) is 1.2 cells: the averaging
    keeps exp(−1.25²/6) = 77 % of the Nyquist wave, so the plan warns; 5 µm (1.56 cells,
    the measured case that converged) does not."""
    from micropit_hpc.plan import make_plan

    said = {ell: make_plan(scene_from_dict(_doc(ell_um=ell), "gear.toml")).warnings
            for ell in (4.0, 5.0, 0.0)}
    assert not said[5.0] and not said[0.0], said
    assert len(said[4.0]) == 1 and ("fatigue.process_length_um = 4 µm is 1.2 grid cells "
                                    "(3.21 µm): the averaging keeps 77 % of the shortest wave"
                                    in said[4.0][0]), said[4.0]


def test_the_default_length_on_a_coarse_window_is_warned_about_as_the_default():
    """A scene that does not name ℓ and whose cells are coarser than 5 µm / 1.5 (the paper
    gear's window on 32²: 6.4 µm cells) is told that the length is the default, and which."""
    from micropit_hpc.plan import make_plan

    said = make_plan(scene_from_dict(_doc(n=32), "gear.toml")).warnings
    assert len(said) == 1 and ("fatigue.process_length_um = 5 µm (the default of "
                               "life.integration = \"adaptive\") is 0.78 grid cells"
                               in said[0]), said
    assert "or set the length" in said[0]
