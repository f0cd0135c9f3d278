"""Bad scene files: each class of mistake gets one line naming the file, the key, the value and
what is allowed (issue: foundation, item 5)."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest
from conftest import ROOT, SCENES

from micropit_hpc.errors import SceneError
from micropit_hpc.scene import load_scene


def broken(tmp_path, old: str, new: str, scene: str = "paper_gear_z23"):
    """Write a copy of a shipped scene with one textual edit; return its path."""
    text = (SCENES / f"{scene}.toml").read_text()
    assert old in text, old
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def error_of(path) -> str:
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert message.startswith(str(path)), message  # names the file
    assert "\n" not in message
    return message


def test_unknown_key_suggests_the_close_match(tmp_path):
    msg = error_of(broken(tmp_path, "module_mm = 3.95", "modul_mm = 3.95"))
    assert "gear.modul_mm" in msg and "did you mean 'module_mm'" in msg


def test_unknown_table_suggests_the_close_match(tmp_path):
    msg = error_of(broken(tmp_path, "[lubricant]", "[lubricnat]"))
    assert "'lubricnat'" in msg and "did you mean 'lubricant'" in msg


def test_unknown_choice_suggests_the_close_match(tmp_path):
    msg = error_of(broken(tmp_path, 'load_sharing = "linear"', 'load_sharing = "linaer"'))
    assert "gear.load_sharing" in msg and 'did you mean "linear"' in msg
    assert '"iso_unmodified"' in msg  # lists what is allowed


@pytest.mark.parametrize("old,new,key,expect", [
    ("teeth = 23", 'teeth = "23"', "gear.pinion.teeth", "expected an integer, got a string"),
    ("teeth = 23", "teeth = 23.5", "gear.pinion.teeth", "expected an integer, got a number"),
    ("facewidth_mm = 19.5", "facewidth_mm = true", "gear.facewidth_mm",
     "expected a number, got a boolean"),
    ("roll_angle_deg = [", "roll_angle_deg = 18.25 #[", "positions.roll_angle_deg",
     "expected a non-empty list of numbers"),
])
def test_wrong_types(tmp_path, old, new, key, expect):
    msg = error_of(broken(tmp_path, old, new))
    assert key in msg and expect in msg


def test_a_table_given_as_a_value(tmp_path):
    text = (SCENES / "paper_gear_z23.toml").read_text()
    text = "body2 = 3\n" + text[:text.index("[body2]")] + text[text.index("[lubricant]"):]
    path = tmp_path / "bad.toml"
    path.write_text(text)
    msg = error_of(path)
    assert "body2 = 3" in msg and "must be a table" in msg


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_nan_and_inf_are_refused(tmp_path, value):
    msg = error_of(broken(tmp_path, "module_mm = 3.95", f"module_mm = {value}"))
    assert f"gear.module_mm = {float(value)!r}" in msg and "finite" in msg


def test_nan_inside_a_list_names_the_element(tmp_path):
    msg = error_of(broken(tmp_path, "21.10,", "nan,"))
    assert "positions.roll_angle_deg[1]" in msg and "finite" in msg


@pytest.mark.parametrize("old,new,key", [
    ("module_mm = 3.95", "module_mm = -3.95", "gear.module_mm"),
    ("facewidth_mm = 19.5", "facewidth_mm = 0", "gear.facewidth_mm"),
    ("torque_Nm = 140.0", "torque_Nm = 0.0", "gear.torque_Nm"),
    ("speed_rpm = 957.0", "speed_rpm = -957.0", "gear.speed_rpm"),
    ("eta0_mPas = 90.0", "eta0_mPas = 0.0", "lubricant.eta0_mPas"),
    ("alpha_pv_1_per_GPa = 21.0", "alpha_pv_1_per_GPa = 0.0", "lubricant.alpha_pv_1_per_GPa"),
    ("E_GPa = 210.0", "E_GPa = -210.0", "body1.E_GPa"),
])
def test_non_positive_sizes(tmp_path, old, new, key):
    msg = error_of(broken(tmp_path, old, new))
    assert key in msg and "out of range" in msg and "> 0" in msg


@pytest.mark.parametrize("nu", ["0.5", "0.6", "-1.0", "-1.5"])
def test_poisson_ratio_outside_minus_one_to_half(tmp_path, nu):
    msg = error_of(broken(tmp_path, "nu = 0.3", f"nu = {nu}"))
    assert f"body1.nu = {float(nu)!r}" in msg and "in (-1, 0.5)" in msg


def test_contact_ratio_below_one(tmp_path):
    path = broken(tmp_path, "tip_diameter_mm = 98.75", "tip_diameter_mm = 94.0")
    path.write_text(path.read_text().replace("tip_diameter_mm = 98.75", "tip_diameter_mm = 94.0"))
    msg = error_of(path)
    assert "contact ratio is 0.4" in msg and "< 1" in msg
    assert "gear.pinion.tip_diameter_mm = 94.0" in msg and "gear.wheel.tip_diameter_mm" in msg


def test_tip_beyond_the_base_circle_of_the_mate(tmp_path):
    """z = 10 : 60 at 20°: the wheel's tip reaches past the pinion's base circle."""
    text = (SCENES / "paper_gear_z23.toml").read_text()
    text = (text.replace("module_mm = 3.95", "module_mm = 1.0")
                .replace("pressure_angle_deg = 25.0", "pressure_angle_deg = 20.0")
                .replace("centre_distance_mm = 91.502", "centre_distance_mm = 35.0")
                .replace("tip_diameter_mm = 98.75", "tip_diameter_mm = 12.0", 1)
                .replace("teeth = 23", "teeth = 10", 1)
                .replace("teeth = 23", "teeth = 60", 1)
                .replace("tip_diameter_mm = 98.75", "tip_diameter_mm = 62.0", 1)
                .replace("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, "
                         "30.63, 33.17, 34.44, 37.30]", "n = 3"))
    path = tmp_path / "interference.toml"
    path.write_text(text)
    msg = error_of(path)
    assert "beyond the base circle of gear 1" in msg and "interference" in msg
    assert "gear.wheel.tip_diameter_mm = 62.0" in msg


def test_tip_inside_own_base_circle(tmp_path):
    msg = error_of(broken(tmp_path, "tip_diameter_mm = 98.75", "tip_diameter_mm = 80.0"))
    assert "no involute flank" in msg and "gear.pinion.tip_diameter_mm = 80.0" in msg


@pytest.mark.parametrize("a,expect", [("80.0", "sum of the base radii"),
                                      ("86.0", "hits the root")])
def test_centre_distance_too_small(tmp_path, a, expect):
    msg = error_of(broken(tmp_path, "centre_distance_mm = 91.502", f"centre_distance_mm = {a}"))
    assert expect in msg and f"gear.centre_distance_mm = {a}" in msg


@pytest.mark.parametrize("old,new,key,allowed", [
    ("18.25,", "40.0,", "positions.roll_angle_deg[0] = 40.0", "17.6124 < value < 37.9356 deg"),
    ("18.25,", "17.6123541,", "positions.roll_angle_deg[0]", "carry no load"),
    ("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, 30.63, 33.17, 34.44, "
     "37.30]", "radial_pos_mm = [43.0, 50.0]", "positions.radial_pos_mm[1] = 50.0",
     "42.8993 < value < 49.3641 mm"),
    ("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, 30.63, 33.17, 34.44, "
     "37.30]", "modules_below_tip = [1.8]", "positions.modules_below_tip[0] = 1.8",
     "0.00275745 < value < 1.63941 modules"),
])
def test_position_outside_the_path_of_contact(tmp_path, old, new, key, allowed):
    msg = error_of(broken(tmp_path, old, new))
    assert key in msg and "outside the loaded path of contact" in msg and allowed in msg


def test_end_of_path_allowed_when_the_load_sharing_loads_it(tmp_path):
    path = broken(tmp_path, 'load_sharing = "linear"', 'load_sharing = "none"')
    path.write_text(path.read_text().replace("18.25,", "17.6124,"))
    assert load_scene(path).positions.values[0] == pytest.approx(math.radians(17.6124))


def test_missing_and_conflicting_keys(tmp_path):
    assert "missing required key 'gear.module_mm'" in error_of(
        broken(tmp_path, "module_mm = 3.95", "# no module"))
    assert "exactly one of positions.roll_angle_deg" in error_of(
        broken(tmp_path, "[positions]", "[positions]\nn = 5"))
    assert "exactly one of the tables [gear]" in error_of(
        broken(tmp_path, "[body1]", "[disc]\nu_mean_m_s = 1.0\n[body1]"))
    assert "missing key 'lubricant.eta0_mPas'" in error_of(
        broken(tmp_path, "eta0_mPas = 90.0", ""))
    msg = error_of(broken(tmp_path, 'model = "DH61"', 'model = "HD77c"'))
    assert 'film.model = "HD77c"' in msg and "line contact" in msg


def test_disc_scene_load_must_fit_the_geometry(tmp_path):
    msg = error_of(broken(tmp_path, "p0_GPa = 1.1", "load_N = 300.0", scene="paper_mpr"))
    assert "disc.load_N = 300.0" in msg and "load_N_per_m or p0_GPa" in msg
    msg = error_of(broken(tmp_path, "slide_roll = [0.05, 0.15, 0.30]",
                          "slide_roll = [0.05, 2.5]", scene="paper_mpr"))
    assert "disc.slide_roll[1] = 2.5" in msg and "in [-2, 2]" in msg


def test_unreadable_files(tmp_path):
    assert "no such scene file" in error_of(tmp_path / "nope.toml")
    bad = tmp_path / "syntax.toml"
    bad.write_text("[gear\nmodule_mm = 3\n")
    assert "not valid TOML" in error_of(bad) and "line 1" in error_of(bad)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "micropit_hpc", *args], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)


def test_cli_prints_one_line_and_exits_non_zero_without_traceback(tmp_path):
    path = broken(tmp_path, "nu = 0.3", "nu = 0.7")
    out = run_cli("contact", str(path))
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert out.stderr.startswith(f"micropit: error: {path}: body1.nu = 0.7: out of range")


def test_cli_debug_shows_the_traceback(tmp_path):
    out = run_cli("contact", str(broken(tmp_path, "nu = 0.3", "nu = 0.7")), "--debug")
    assert out.returncode != 0 and "Traceback" in out.stderr and "SceneError" in out.stderr
