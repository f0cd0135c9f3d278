"""ISO/TS 6336-22 Method B beside A_p (issue 20): λ_GF,min, λ_GFT, λ_GFP, S_λ."""

from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from micropit_hpc.conditions import contact_study
from micropit_hpc.errors import SceneError
from micropit_hpc.iso6336_22 import (
    FZG_TORQUE_NM,
    fzg_lambda_gft,
    method_b,
    permissible_lambda,
    safety,
)
from micropit_hpc.oil import oil_at
from micropit_hpc.scene import scene_from_dict


def gear_doc(**lub):
    """The issue's gear pair: z 20/41, m 4, 20°, shifts +0.2/−0.1, 500 N·m, 1500 rpm, ISO VG
    220 at 70 °C."""
    return {"gear": {"module_mm": 4.0, "pressure_angle_deg": 20.0, "facewidth_mm": 20.0,
                     "torque_Nm": 500.0, "speed_rpm": 1500.0,
                     "pinion": {"teeth": 20, "profile_shift": 0.2},
                     "wheel": {"teeth": 41, "profile_shift": -0.1}},
            "positions": {"n": 7},
            "body1": {"Rq_um": 0.5}, "body2": {"Rq_um": 0.5},
            "lubricant": {"iso_vg": 220, "nu100_cSt": 19.0, "temperature_C": 70.0, **lub}}


def test_worked_example_by_hand():
    """Film fixed at h = 0.3 µm, R_a 0.4 and 0.2 µm: λ_GF = 0.3/½(0.4 + 0.2) = 1 everywhere;
    λ_GFT = 0.25, W_W = 1.2: λ_GFP = 1.4 × 1.2 × 0.25 = 0.42; S_λ = 1/0.42 = 2.381."""
    doc = gear_doc(lambda_GFT=0.25)
    doc["film"] = {"hc_um": 0.3}
    doc["gear"]["material_factor_WW"] = 1.2
    doc["body1"]["Ra_um"], doc["body2"]["Ra_um"] = 0.4, 0.2
    mb = method_b(contact_study(scene_from_dict(doc, "w.toml")))
    np.testing.assert_allclose(mb.lambda_gf, 1.0, rtol=1e-12)
    assert mb.ra == pytest.approx(0.3e-6)
    assert mb.lambda_gf_min == pytest.approx(1.0)
    assert mb.lambda_gfp == pytest.approx(0.42)
    assert mb.s_lambda == pytest.approx(1 / 0.42)
    text = "\n".join(mb.lines())
    assert "λ_GFP = 1.4 W_W λ_GFT = 1.4 × 1.2 × 0.25 = 0.42" in text
    assert "S_λ = λ_GF,min/λ_GFP = 2.381 (≥ 1: micropitting not expected)" in text
    assert permissible_lambda(0.25, 1.2) == pytest.approx(0.42)
    assert safety(0.21, 0.42) == pytest.approx(0.5)


def test_lambda_gf_along_the_path_is_the_film_over_ra_and_its_minimum():
    scene = scene_from_dict(gear_doc(), "g.toml")
    study = contact_study(scene)
    mb = method_b(study)
    m = study.mesh
    # the ends of the path are A and E; R_a defaults to √(2/π) R_q
    assert math.degrees(mb.roll_angle[0]) == pytest.approx(math.degrees(m.A / m.rb1))
    assert math.degrees(mb.roll_angle[-1]) == pytest.approx(math.degrees(m.E / m.rb1))
    assert mb.ra == pytest.approx(math.sqrt(2 / math.pi) * 0.5e-6)
    k = int(np.argmin(mb.lambda_gf))
    assert mb.lambda_gf_min == mb.lambda_gf[k] and mb.roll_angle_min == mb.roll_angle[k]
    # every position of the study lies on the curve, and none below its minimum
    ra = mb.ra
    for c in study.conditions:
        assert c.hc / ra >= mb.lambda_gf_min * (1 - 1e-12)
    assert math.isnan(mb.lambda_gfp) and math.isnan(mb.s_lambda)
    assert "give lubricant.micropitting_load_stage" in mb.lines()[1]


def test_lambda_gft_follows_the_film_formula_between_load_stages_and_temperatures():
    """λ_GFT of the FZG C gears scales as DH61 does: h ∝ w^−0.13 between load stages (same
    geometry and speeds), and ∝ η0^0.7 α^0.6 between test temperatures."""
    scene = scene_from_dict(gear_doc(micropitting_load_stage=9), "g.toml")
    l5, l10 = fzg_lambda_gft(scene, 5, 90.0), fzg_lambda_gft(scene, 10, 90.0)
    assert l5 / l10 == pytest.approx((FZG_TORQUE_NM[5] / FZG_TORQUE_NM[10]) ** -0.13, rel=1e-9)
    l60 = fzg_lambda_gft(scene, 9, 60.0)
    l90 = fzg_lambda_gft(scene, 9, 90.0)
    o60, o90 = oil_at(220.0, 19.0, 60.0), oil_at(220.0, 19.0, 90.0)
    assert l60 / l90 == pytest.approx((o60.eta0 / o90.eta0) ** 0.7 * (o60.alpha / o90.alpha) ** 0.6,
                                      rel=1e-9)
    assert 0.1 < l90 < 2.0
    mb = method_b(contact_study(scene))
    assert mb.lambda_gft == pytest.approx(l90)
    assert mb.lambda_gfp == pytest.approx(1.4 * l90)
    assert mb.s_lambda == pytest.approx(mb.lambda_gf_min / (1.4 * l90))
    assert "load stage 9 (302 N·m), 90 °C" in mb.lines()[1]


def test_a_load_stage_without_the_oil_by_grade_is_a_clear_error():
    doc = gear_doc(micropitting_load_stage=9)
    doc["lubricant"] = {"eta0_mPas": 40.0, "alpha_pv_1_per_GPa": 20.0,
                        "micropitting_load_stage": 9}
    with pytest.raises(SceneError, match="lubricant.micropitting_load_stage = 9: λ_GFT"):
        scene_from_dict(doc, "g.toml")


def test_contact_shows_lambda_gf_and_s_lambda(tmp_path, capsys):
    from helpers import write_scene

    from micropit_hpc.cli import main

    path = write_scene(tmp_path / "g.toml", gear_doc(micropitting_load_stage=9))
    assert main(["contact", str(path)]) == 0
    out = capsys.readouterr().out
    assert "# ISO/TS 6336-22:2018 Method B: λ_GF,Y = h_Y/R_a" in out
    assert "S_λ = λ_GF,min/λ_GFP = " in out
    rows = list(csv.DictReader(io.StringIO("\n".join(
        ln for ln in out.splitlines() if not ln.startswith("#")))))
    ra = math.sqrt(2 / math.pi) * 0.5
    for r in rows:
        assert float(r["lambda_GF"]) == pytest.approx(float(r["hc_um"]) / ra, rel=1e-4)
