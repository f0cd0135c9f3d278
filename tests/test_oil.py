"""The oil by grade (issue 20): ASTM D341 viscosity, Wooster's α, scene keys, unit warnings."""

from __future__ import annotations

import math

import pytest
from helpers import tiny_doc

from micropit_hpc.errors import SceneError
from micropit_hpc.oil import density, oil_at, walther_constants, walther_viscosity, wooster_alpha
from micropit_hpc.scene import scene_from_dict


def test_walther_passes_through_both_points_and_is_a_straight_line_on_the_astm_chart():
    assert walther_viscosity(220.0, 19.0, 40.0) == pytest.approx(220.0, rel=1e-12)
    assert walther_viscosity(220.0, 19.0, 100.0) == pytest.approx(19.0, rel=1e-12)
    A, B = walther_constants(220.0, 19.0)
    for t in (0.0, 70.0, 120.0):   # log log(ν + 0.7) linear in log T, falling
        nu = walther_viscosity(220.0, 19.0, t)
        assert math.log10(math.log10(nu + 0.7)) == pytest.approx(
            A - B * math.log10(t + 273.15), rel=1e-12)
    assert B > 0
    nu70 = walther_viscosity(220.0, 19.0, 70.0)
    # by hand: W40 = loglog(220.7) = 0.36992, W100 = loglog(19.7) = 0.11209, B = 3.3867,
    # W70 = W40 − B log(343.15/313.15) = 0.23536 ⇒ ν = 10^10^0.23536 − 0.7 = 51.7 mm²/s
    assert nu70 == pytest.approx(51.7, abs=0.1)


@pytest.mark.parametrize("eta_cP,alpha_measured", [
    # Stachowiak & Batchelor, Engineering Tribology, Table 2.3 (mineral oils at 30/60/100 °C):
    # η [cP] and measured α [1/GPa]
    (153, 23.7), (34, 20.5), (9.1, 15.8),        # heavy machine oil
    (250, 25.0), (50.5, 21.3), (12.6, 17.6),     # heavy machine oil
    (810, 34.0), (135, 28.0), (26.8, 22.0),      # cylinder oil
])
def test_wooster_alpha_is_within_20_percent_of_measured_mineral_oils(eta_cP, alpha_measured):
    assert wooster_alpha(eta_cP * 1e-3) * 1e9 == pytest.approx(alpha_measured, rel=0.2)


def test_density_falls_by_0_07_percent_per_kelvin():
    assert density(880.0, 15.0) == 880.0
    assert density(880.0, 115.0) == pytest.approx(880.0 * 0.93)


def grade_doc(**lub):
    doc = tiny_doc()
    doc.pop("film")
    doc["lubricant"] = {"iso_vg": 220, "nu100_cSt": 19.0, "temperature_C": 70.0,
                        "eyring_stress_MPa": 5.0, **lub}
    return doc


def test_a_grade_gives_eta0_and_alpha_and_says_how():
    scene = scene_from_dict(grade_doc(), "g.toml")
    oil = oil_at(220.0, 19.0, 70.0)
    lub = scene.lubricant
    assert lub.eta0 == pytest.approx(oil.eta0) and lub.alpha_pv == pytest.approx(oil.alpha)
    assert oil.eta0 == pytest.approx(51.7e-6 * 880 * (1 - 7e-4 * 55), rel=2e-3)
    assert "ASTM D341" in lub.derived and "Wooster" in lub.derived and "70 °C" in lub.derived
    # explicit keys win, and the line says so
    scene = scene_from_dict(grade_doc(eta0_mPas=30.0, alpha_pv_1_per_GPa=18.0), "g.toml")
    assert scene.lubricant.eta0 == pytest.approx(0.030)
    assert scene.lubricant.alpha_pv == pytest.approx(18e-9)
    assert "given by lubricant.eta0_mPas" in scene.lubricant.derived
    # the same oil by nu40_cSt
    by_nu = grade_doc(nu40_cSt=220.0)
    del by_nu["lubricant"]["iso_vg"]
    assert scene_from_dict(by_nu, "g.toml").lubricant.eta0 == pytest.approx(oil.eta0)


@pytest.mark.parametrize("change,words", [
    ({"iso_vg": 200}, "lubricant.iso_vg = 200: not an ISO 3448 viscosity grade"),
    ({"nu100_cSt": None}, "missing: nu100_cSt"),
    ({"temperature_C": None}, "missing: temperature_C"),
    ({"nu100_cSt": 250.0}, "lubricant.nu100_cSt = 250"),
    ({"nu40_cSt": 200.0}, "either lubricant.iso_vg or lubricant.nu40_cSt"),
    ({"iso_vg": 10, "nu100_cSt": 2.6, "temperature_C": 200.0}, "lubricant.temperature_C = 200"),
])
def test_bad_grades_are_one_line_errors_naming_the_key(change, words):
    doc = grade_doc()
    for k, v in change.items():
        if v is None:
            del doc["lubricant"][k]
        else:
            doc["lubricant"][k] = v
    with pytest.raises(SceneError) as e:
        scene_from_dict(doc, "g.toml")
    assert words in str(e.value) and "\n" not in str(e.value)


def test_values_in_the_wrong_unit_are_warned_about():
    doc = tiny_doc()
    doc["lubricant"]["eta0_mPas"] = 0.044        # Pa·s
    doc["body2"]["Rq_um"] = 5e-7                 # metres
    w = scene_from_dict(doc, "w.toml").warnings
    assert any(x.startswith("w.toml: lubricant.eta0_mPas = 0.044 looks like a value in Pa·s")
               for x in w)
    assert any(x.startswith("w.toml: body2.Rq_um = 5e-07 looks like a value in metres")
               for x in w)
    assert len(w) == 2
    assert scene_from_dict(tiny_doc(), "ok.toml").warnings == ()


def test_contact_prints_the_oil_and_the_warnings(tmp_path, capsys):
    from helpers import write_scene

    from micropit_hpc.cli import main

    doc = grade_doc()
    doc["body1"]["Rq_um"] = 5e-7
    assert main(["contact", str(write_scene(tmp_path / "g.toml", doc))]) == 0
    out = capsys.readouterr()
    assert "# lubricant at 70 °C: η0 = ν ρ = " in out.out
    assert "micropit: warning: " in out.err and "body1.Rq_um = 5e-07" in out.err
