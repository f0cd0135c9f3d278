"""The stress history that feeds Dang Van honours the contact (docs/contact.md, "The stress
history"): in each body's material frame σ_zz(0) = −p and σ_xz(0) = −q at every step, the
moved pressure stays in [0, p_lim], and an elastic Hertzian asperity carried through the
window gives the Dang Van stress of the closed-form point-contact field along the same path."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import SCENES
from test_life import tiny_doc

from micropit_hpc.conditions import contact_study
from micropit_hpc.cycle import PositionCycle
from micropit_hpc.scene import scene_from_dict
from micropit_hpc.spectral import to_material_frame


def _cycle(tmp_path, base: str, position: int) -> PositionCycle:
    """Position ``position`` of a shipped scene on a 32² window with 5 layers."""
    doc = tomllib.loads((SCENES / f"{base}.toml").read_text())
    doc.setdefault("window", {})["n"] = 32
    doc.setdefault("stress", {})["layers"] = 5
    return PositionCycle(contact_study(scene_from_dict(doc, f"{base}.toml")), position)


def _elliptical(tmp_path) -> PositionCycle:
    doc = tiny_doc(slide_roll=(0.3,))
    doc["disc"].update(radius1_y_mm=6.0, radius2_y_mm=20.0)
    doc["window"] = {"n": 32, "steps": 6}
    return PositionCycle(contact_study(scene_from_dict(doc, "ellipse.toml")), 1)


@pytest.mark.parametrize("case", ["gear", "mpr", "ellipse"])
def test_surface_tractions_hold_at_every_step(tmp_path, case):
    """σ_zz(0) = −p, σ_xz(0) = −q, σ_yz(0) = 0 in each body's material frame at every step of a
    paper-gear cycle (position 3, single-pair zone, S = −0.39), an MPR cycle (|S| = 0.3) and an
    elliptical disc contact, to round-off (the elliptical macro field is a numerical DC-FFT
    field, accurate to 1e-3 p0, so there to that: tests/test_hertz_field.py); the moved
    pressure within [0, p_lim], with its mean p̄_j; no tension on the surface. (Before the fix
    the macro field was taken at each point's own position and the maps moved by a Fourier
    shift: up to +1.5 p0 of σ_zz on free surface points of the gear.)"""
    cyc = {"gear": lambda: _cycle(tmp_path, "paper_gear_z23", 3),
           "mpr": lambda: _cycle(tmp_path, "paper_mpr", 3),
           "ellipse": lambda: _elliptical(tmp_path)}[case]()
    assert cyc.z[0] == 0.0 and cyc.level in ("mixed", "dry")
    assert (cyc.cond.geometry == "line") == (case != "ellipse")
    p0, g = cyc.cond.p0, cyc.grid
    tol = 1e-9 if case != "ellipse" else 2e-3
    worst, p_prev = 0.0, None
    for j in range(cyc.steps):
        f = cyc.solve_step(j, p_prev)
        p_prev = f.pressure
        for body in (1, 2):
            p, q = cyc.material_tractions(f, body)
            assert p.min() >= 0.0 and p.max() <= cyc.p_lim * (1 + 1e-12)
            assert p.mean() == pytest.approx(f.p_mean, rel=1e-10, abs=1e-9 * p0)
            # the maps are the window's, read at X + (u_i − ū)t (linear interpolation)
            cells = cyc.slip(body, f.t) / g.dx
            k = int(np.floor(cells))
            w = cells - k
            expect = (1 - w) * np.roll(f.pressure, -k, 0) + w * np.roll(f.pressure, -k - 1, 0)
            np.testing.assert_allclose(p, expect, rtol=0, atol=1e-9 * p0)
            s0 = cyc.stresses(f, body)[:, 0]
            err = max(np.abs(s0[2] + p).max(), np.abs(s0[4] + q).max(), np.abs(s0[3]).max())
            worst = max(worst, err / p0)
            assert s0[2].max() <= tol * p0               # never tension on the surface
    assert worst < tol


def test_material_frame_transfer_keeps_bounds_and_sum():
    """Linear interpolation into the material frame: exact for whole cells, the sum kept, a
    capped plateau with sharp edges never below 0 or above its cap (a Fourier shift of the
    same map by half a cell rings on both sides)."""
    rng = np.random.default_rng(3)
    p = np.where(rng.random((40, 8)) < 0.3, 3.0, 0.0)     # capped spots, sharp edges
    for s in (0.0, 1.0, 2.5, -3.25, 17.9):
        m = to_material_frame(p, s * 0.5, 0.5)
        assert m.min() >= 0.0 and m.max() <= 3.0
        assert m.sum() == pytest.approx(p.sum(), rel=1e-14)
        if s == int(s):
            np.testing.assert_array_equal(m, np.roll(p, -int(s), 0))
    k = np.fft.fftfreq(40) * 40
    ringing = np.fft.ifft(np.fft.fft(p, axis=0) * np.exp(2j * np.pi * k * 0.5 / 40)[:, None],
                          axis=0).real
    assert ringing.min() < -0.1 and ringing.max() > 3.1
