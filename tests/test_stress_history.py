"""The stress history that feeds Dang Van honours the contact (docs/contact.md, "The stress
history"): in each body's material frame σ_zz(0) = −p and σ_xz(0) = −q at every step, the
moved pressure stays in [0, p_lim], and an elastic Hertzian asperity carried through the
window gives the Dang Van stress of the closed-form point-contact field along the same path."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from helpers import SCENES, process_averaged, tiny_doc

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
    """σ_zz(0) = −p̃, σ_xz(0) = −q̃, σ_yz(0) = 0 in each body's material frame at every step of a
    paper-gear cycle (position 3, single-pair zone, S = −0.39), an MPR cycle (|S| = 0.3) and an
    elliptical disc contact, to round-off (the elliptical macro field is a numerical DC-FFT
    field, accurate to 1e-3 p0, so there to that: tests/test_hertz_field.py; at the surface
    next to the contact's edge, |x_c| > 0.8 b, where the cosine steps also fall, only to ~3e-2
    p0, its documented accuracy there); the moved pressure within [0, p_lim], with its mean
    p̄_j; no tension on the surface (p̃, q̃: the maps averaged over the process area of the
    default ℓ = 5 µm, tests/helpers.process_averaged). (Before the fix the macro field was
    taken at each point's own position and the maps moved by a Fourier shift: up to +1.5 p0 of
    σ_zz on free surface points of the gear.)"""
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
        edge = case == "ellipse" and abs(f.x_c) > 0.8 * cyc.cond.b
        tol_j = 4e-2 if edge else tol
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
            pa, qa = process_averaged(cyc, p, q)           # what the criterion sees
            err = max(np.abs(s0[2] + pa).max(), np.abs(s0[4] + qa).max(), np.abs(s0[3]).max())
            assert err < tol_j * p0
            worst = max(worst, err / p0) if not edge else worst
            assert s0[2].max() <= tol_j * p0             # never tension on the surface
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


# ---- an elastic Hertzian asperity carried through the window ------------------------------------
P0_ASPERITY, MU_ASPERITY, A_ASPERITY = 4.2e9, 0.11, 10e-6


def _asperity_cycle(monkeypatch) -> PositionCycle:
    """A disc position whose window is 32 a square (a = 10 µm, 12 cells per a) with 23 uniform
    layers down to 0.55 a, around the depth of the largest Dang Van stress of a Hertzian point
    contact. Only its frame transfer, micro kernels and stress assembly are used: the fields
    are made by hand and the macro part is the uniform state of the mean tractions."""
    doc = tiny_doc(slide_roll=(0.3,))
    a = A_ASPERITY
    doc["window"] = {"n": 384, "length_x_um": 32 * a * 1e6, "steps": 8}
    doc["lubrication"] = {"model": "dry"}
    doc["fatigue"] = {"process_length_um": 0.0}      # Hamilton's field is the pointwise one
    b_ref = contact_study(scene_from_dict(doc, "asperity.toml")).conditions[0].b
    doc["stress"] = {"layers": 23, "spacing": "uniform", "depth_b": 0.55 * a / b_ref}
    cyc = PositionCycle(contact_study(scene_from_dict(doc, "asperity.toml")), 1)
    assert cyc.z[-1] == pytest.approx(0.55 * a, rel=1e-12) and cyc.grid.dx == pytest.approx(a / 12)

    def uniform_mean_state(fields, body):     # a uniform p̄, q̄ on the half-space
        s = np.zeros((6, cyc.z.size, 1, 1))
        s[2] = -fields.pressure.mean()
        s[4] = -fields.traction1.mean()
        return s

    monkeypatch.setattr(cyc, "macro_stress", uniform_mean_state)
    return cyc


def _asperity_dang_van(cyc, monkeypatch, m: int, whole_cells: bool):
    """τ_DV along the asperity's path through body 1: the asperity (fixed to body 2) moves
    by r_j from −3a to 3a relative to body 1, which itself slips by s1 = −0.37 r_j in the
    window (fractional cells) or s1 = −r_j with r_j a whole number of cells. Returns the
    depth profiles (largest τ_DV over the path's central points per layer) of the code and of
    the closed-form Hamilton (1983) field along the same path, both through
    :func:`~micropit_hpc.fatigue.dangvan.dang_van`."""
    from hamilton import hamilton_stresses

    from micropit_hpc.cycle import StepFields
    from micropit_hpc.fatigue.dangvan import dang_van

    g, a, z = cyc.grid, A_ASPERITY, cyc.z
    x = g.x - g.x[g.nx // 2]
    y = g.y - g.y[g.ny // 2]
    X, Y = np.meshgrid(x, y, indexing="ij")
    row = g.ny // 2
    code, ref = np.empty((m, 6, z.size, g.nx)), np.empty((m, 6, z.size, g.nx))
    slips = {}
    monkeypatch.setattr(cyc, "slip", lambda body, t: slips[t][body - 1])
    for j in range(m):
        if whole_cells:
            r = round((-3 * a + 6 * a * j / (m - 1)) / g.dx) * g.dx
            s1 = -r
        else:
            r = -3 * a + 6 * a * (j + 0.5) / m
            s1 = -0.37 * r
        s2 = s1 + r
        slips[float(j)] = (s1, s2)
        p = P0_ASPERITY * np.sqrt(np.maximum(0.0, 1 - ((X - s2) ** 2 + Y ** 2) / a**2))
        q = MU_ASPERITY * p                                   # friction on body 1 along +x
        f = StepFields(position=1, step=j, t=float(j), x_c=0.0, p_mean=float(p.mean()),
                       level="dry", pressure=p, clearance=np.zeros_like(p),
                       solid=p > 0, friction=np.full_like(p, MU_ASPERITY), phi=1.0,
                       iterations=0, traction1=q, traction2=-q)
        code[j] = cyc.stresses(f, 1)[:, :, :, row]
        ref[j] = hamilton_stresses((x - r)[None, :], 0.0, z[:, None], a, P0_ASPERITY,
                                   MU_ASPERITY, 0.3)
    central = np.abs(x) < 1.5 * a                             # they see the whole passage
    return tuple(dang_van(h).tau_dv[:, central].max(axis=1) for h in (code, ref))


def test_a_hertzian_asperity_through_the_window_gives_hamiltons_dang_van(monkeypatch):
    """An elastic Hertzian asperity (point contact, p0 = 4.2 GPa, μ = 0.11, ν = 0.3, radius a)
    of body 2 slides 6a past body 1 through the window: the code's stress history (pressure
    and traction moved into body 1's frame, FFT kernels, mean state) gives the Dang Van stress
    of an independent evaluation from the closed-form Hamilton (1983) point-contact field
    along the same path: the largest τ_DV within 1 %, at a depth where the reference is within
    1 % of its own largest; with fractional-cell and with whole-cell slips, which agree
    within 1 %.

    Measured (12 cells per a, 32 a window, layers every 0.025 a): τ_DV +0.4 % (fractional)
    and +0.6 % (whole cells), largest at 0.375 a against the reference's 0.375 a and 0.40 a.
    The depth of the largest τ_DV is ill-conditioned, so it is compared on the reference's
    plateau rather than as a number: the profile is flat there (within 0.7 % from 0.35 a to
    0.45 a), and the closed-form field alone moves its maximum from 0.37 a to 0.42 a between
    two time samplings of the same path. Above 0.25 a the profiles differ by up to 10 %: there
    the sampled edge of the contact (one cell is a/12) sets the stresses."""
    cyc = _asperity_cycle(monkeypatch)
    peaks = {}
    for whole, m in ((False, 72), (True, 73)):
        code, ref = _asperity_dang_van(cyc, monkeypatch, m, whole)
        top = ref.max()
        assert 0 < np.argmax(ref) < len(ref) - 1                      # inside the layers
        assert code.max() == pytest.approx(top, rel=0.01)
        assert ref[np.argmax(code)] > 0.99 * top
        peaks[whole] = code.max()
    assert peaks[True] == pytest.approx(peaks[False], rel=0.01)
