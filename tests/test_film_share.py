"""The Gaussian-ACF surfaces are band-limited, and the MPR rig's film share converges with
the grid (issue 29 item 4; docs/performance.md, "The MPR rig's film share")."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.plan import reference_half_width, window_grid
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.spectral import Grid
from micropit_hpc.surfaces import gaussian_surface
from micropit_hpc.surfaces.bodies import body_surface

ROOT = Path(__file__).resolve().parent.parent
UM = 1e-6


def high_share(h: np.ndarray, fraction: float = 0.5) -> float:
    """Share of the variance at |k_x| or |k_y| above ``fraction`` of the Nyquist."""
    nx, ny = h.shape
    P = np.abs(np.fft.fft2(h)) ** 2
    fx = np.abs(np.fft.fftfreq(nx))[:, None] * 2
    fy = np.abs(np.fft.fftfreq(ny))[None, :] * 2
    return float(P[(fx > fraction) | (fy > fraction)].sum() / P.sum())


@pytest.mark.parametrize("acf", ["gaussian", "exponential"])
def test_periodic_acf_is_the_sum_of_the_images(acf):
    """The field's spectrum is the DFT of R + its images: at β = 0.9 L/2 across (the paper
    scenes' β_y against their window) the ACF of the generated field at the half-window lag is
    2 R(L/2) (the two images meet there), not R(L/2)."""
    from micropit_hpc.surfaces.synthetic import _periodic_acf
    g = Grid(64, 64, 64 * UM, 64 * UM)
    by = 0.9 * 32 * UM
    r = _periodic_acf(g, 8 * UM, by, acf)

    def images(lag):      # Σ_m R(lag + m L) along y (the x images are below 1e-7 here)
        d = np.abs(lag + 64 * UM * np.arange(-20, 21)) / by
        return float(np.exp(-math.log(10) * (d if acf == "exponential" else d * d)).sum())

    assert r[0, 32] == pytest.approx(images(32 * UM), rel=1e-6)
    assert r[0, 32] > 1.9 * images(32 * UM) / 2 > 0.07       # R(L/2) twice, not once
    assert r[0, 0] == pytest.approx(images(0.0), rel=1e-6)
    assert r[5, 7] == pytest.approx(r[-5, -7], rel=1e-12)


def test_gaussian_acf_surface_is_band_limited_when_the_window_is_short():
    """β_y = 0.9 × L/2 (R(L/2) = 0.08): the old minimum-image ACF had a kink at ±L/2 and put
    1e-3 of the variance above half the Nyquist (the tail ∝ k⁻² a finer grid kept resolving);
    the periodic ACF leaves only round-off there."""
    g = Grid(256, 256, 187 * UM, 187 * UM)
    by = 0.9 * g.ly / 2
    new = gaussian_surface(g, 0.2 * UM, 30 * UM, by, 3, acf="gaussian").heights
    old = gaussian_surface(g, 0.2 * UM, 30 * UM, by, 3, acf="gaussian",
                           periodic_acf=False).heights
    assert high_share(old) > 1e-4
    assert high_share(new) < 1e-10


def _mpr(n: int):
    with open(ROOT / "scenes/paper_mpr_beta30.toml", "rb") as f:
        doc = tomllib.load(f)
    doc["window"] = {**doc.get("window", {}), "n": n}
    scene = scene_from_dict(doc, f"paper_mpr_beta30 (n = {n})")
    study = contact_study(scene)
    return scene, study, window_grid(scene, reference_half_width(study))


def test_mpr_film_share_converges_with_the_grid():
    """The MPR rig at |S| = 0.30 (position 3), one realisation made on 256² and resampled:
    φ at the first quarter of the contact agrees within 0.5 % on 64² and 128². With the old
    ACF it rose 0.231 → 0.264 (+14 %): the grid resolved more of the spurious tail."""
    scene, study, grid = _mpr(256)
    ref = tuple(body_surface(scene, i, grid) for i in (1, 2))
    phis = []
    for n in (64, 128):
        _, st, g = _mpr(n)
        cyc = PositionCycle(st, 3, surfaces=tuple(s.resampled(g) for s in ref))
        phis.append(cyc.solve_step(5).phi)
    assert phis[0] > 0.1
    assert phis[1] == pytest.approx(phis[0], rel=5e-3)
