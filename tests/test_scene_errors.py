"""Bad scene files: each class of mistake gets one line naming the file, the key, the value and
what is allowed (issue: foundation, item 5)."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest
from helpers import ROOT, SCENES

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


@pytest.mark.parametrize("old,new,key,allowed", [
    ("module_mm = 3.95", "module_mm = -3.95", "gear.module_mm", "in [0.01, 1000] (mm)"),
    ("facewidth_mm = 19.5", "facewidth_mm = 0", "gear.facewidth_mm", "in [0.001, 100000] (mm)"),
    ("torque_Nm = 140.0", "torque_Nm = 0.0", "gear.torque_Nm", "in (0, 1e+09] (N·m)"),
    ("speed_rpm = 957.0", "speed_rpm = -957.0", "gear.speed_rpm", "in (0, 1e+06] (rpm)"),
    ("eta0_mPas = 90.0", "eta0_mPas = 0.0", "lubricant.eta0_mPas", "in (0, 1e+09] (mPa·s)"),
    ("alpha_pv_1_per_GPa = 21.0", "alpha_pv_1_per_GPa = 0.0", "lubricant.alpha_pv_1_per_GPa",
     "in (0, 1000] (1/GPa)"),
    ("E_GPa = 210.0", "E_GPa = -210.0", "body1.E_GPa", "in (0, 10000] (GPa)"),
])
def test_non_positive_sizes(tmp_path, old, new, key, allowed):
    msg = error_of(broken(tmp_path, old, new))
    assert key in msg and "out of range" in msg and f"(allowed: a number {allowed})" in msg


@pytest.mark.parametrize("old,new,key", [
    ("module_mm = 3.95", "module_mm = 1e-300", "gear.module_mm"),
    ("torque_Nm = 140.0", "torque_Nm = 1e308", "gear.torque_Nm"),
    ("speed_rpm = 957.0", "speed_rpm = 1e300", "gear.speed_rpm"),
    ("facewidth_mm = 19.5", "facewidth_mm = 1e-300", "gear.facewidth_mm"),
])
def test_absurd_magnitudes_are_refused_by_name(tmp_path, old, new, key):
    msg = error_of(broken(tmp_path, old, new))
    assert key in msg and "out of range" in msg


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


def small_pair(tmp_path, z1: int, tip1_mm: float, z2: int, tip2_mm: float):
    """A module-1, 20° pair at a = 35 mm with the given teeth and tip diameters."""
    text = (SCENES / "paper_gear_z23.toml").read_text()
    text = (text.replace("module_mm = 3.95", "module_mm = 1.0")
                .replace("pressure_angle_deg = 25.0", "pressure_angle_deg = 20.0")
                .replace("centre_distance_mm = 91.502", "centre_distance_mm = 35.0")
                .replace("teeth = 23", f"teeth = {z1}", 1)
                .replace("tip_diameter_mm = 98.75", f"tip_diameter_mm = {tip1_mm}", 1)
                .replace("teeth = 23", f"teeth = {z2}", 1)
                .replace("tip_diameter_mm = 98.75", f"tip_diameter_mm = {tip2_mm}", 1)
                .replace("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, "
                         "30.63, 33.17, 34.44, 37.30]", "n = 3"))
    path = tmp_path / "pair.toml"
    path.write_text(text)
    return path


def test_tip_beyond_the_base_circle_of_the_mate(tmp_path):
    """z = 10 : 60 at 20°: the wheel's tip reaches past the pinion's base circle."""
    msg = error_of(small_pair(tmp_path, 10, 12.0, 60, 62.0))
    assert "beyond the base circle of gear 1" in msg and "interference" in msg
    assert "gear.wheel.tip_diameter_mm = 62.0" in msg


def test_tip_of_the_pinion_beyond_the_base_circle_of_the_wheel(tmp_path):
    """The mirror case, 60 : 10: the pinion's tip reaches past the wheel's base circle."""
    msg = error_of(small_pair(tmp_path, 60, 62.0, 10, 12.0))
    assert "tip of gear 1 reaches" in msg and "beyond the base circle of gear 2" in msg
    assert "gear.pinion.tip_diameter_mm = 62.0" in msg


def test_centre_distance_below_zero_backlash_overlaps_the_teeth(tmp_path):
    """Shifted gears (x = 0.5 each) need a ≥ 94.49 mm; 91.502 mm would overlap the teeth."""
    path = broken(tmp_path, "profile_shift = 0.0", "profile_shift = 0.5")
    path.write_text(path.read_text().replace("profile_shift = 0.0", "profile_shift = 0.5"))
    msg = error_of(path)
    assert "smaller than the zero-backlash centre distance 94.49" in msg
    assert "gear.centre_distance_mm = 91.502" in msg and "gear.pinion.profile_shift = 0.5" in msg


def test_pointed_teeth(tmp_path):
    """z = 8 with x = 1.5 at 20° and the standard tip: the tooth is pointed below its tip."""
    text = (SCENES / "gear_z23.toml").read_text()
    text = (text.replace("pressure_angle_deg = 25.0", "pressure_angle_deg = 20.0")
                .replace("centre_distance_mm = 91.502\n", "")
                .replace("teeth = 23\ntip_diameter_mm = 98.75", "teeth = 8\nprofile_shift = 1.5",
                         1)
                .replace("tip_diameter_mm = 98.75\n", ""))
    path = tmp_path / "pointed.toml"
    path.write_text(text)
    msg = error_of(path)
    assert "teeth of gear 1 come to a point" in msg and "gear.pinion.profile_shift = 1.5" in msg


def test_tip_inside_own_base_circle(tmp_path):
    msg = error_of(broken(tmp_path, "tip_diameter_mm = 98.75", "tip_diameter_mm = 80.0"))
    assert "no involute flank" in msg and "gear.pinion.tip_diameter_mm = 80.0" in msg


@pytest.mark.parametrize("a,expect", [("80.0", "sum of the base radii"),
                                      ("86.0", "zero-backlash centre distance 90.85")])
def test_centre_distance_too_small(tmp_path, a, expect):
    msg = error_of(broken(tmp_path, "centre_distance_mm = 91.502", f"centre_distance_mm = {a}"))
    assert expect in msg and f"gear.centre_distance_mm = {a}" in msg


def test_tip_hits_the_root_of_the_mate(tmp_path):
    text = (SCENES / "paper_gear_z23.toml").read_text()
    path = tmp_path / "clash.toml"
    path.write_text(text.replace("[gear.wheel]\n", "[gear.wheel]\nroot_diameter_mm = 86.0\n"))
    msg = error_of(path)
    assert "the tip of gear 1 hits the root of gear 2" in msg
    assert "gear.wheel.root_diameter_mm = 86.0" in msg


@pytest.mark.parametrize("old,new,key,allowed", [
    ("18.25,", "40.0,", "positions.roll_angle_deg[0] = 40.0",
     "17.6123541 < value < 37.9355887 deg"),
    ("18.25,", "17.6123541,", "positions.roll_angle_deg[0]", "carry no load"),
    ("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, 30.63, 33.17, 34.44, "
     "37.30]", "radial_pos_mm = [43.0, 50.0]", "positions.radial_pos_mm[1] = 50.0",
     "42.8993195 < value < 49.3641081 mm"),
    ("roll_angle_deg = [18.25, 21.10, 22.38, 24.92, 27.14, 27.77, 28.41, 30.63, 33.17, 34.44, "
     "37.30]", "modules_below_tip = [1.8]", "positions.modules_below_tip[0] = 1.8",
     "0.002757449 < value < 1.63941279 modules"),
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
    assert 'film.model = "HD77c"' in msg and "a line contact; its film model is DH61 or DH66" in msg
    crowned = broken(tmp_path, "radius2_x_mm = 27.075",
                     "radius2_x_mm = 27.075\nradius1_y_mm = 20.0", scene="paper_mpr")
    crowned.write_text(crowned.read_text().replace('lambda_roughness = "body2"',
                                                   'lambda_roughness = "body2"\nmodel = "DH61"'))
    msg = error_of(crowned)
    assert 'film.model = "DH61"' in msg and "an elliptical contact; its film model is HD77c" in msg


def test_disc_crown_that_makes_a_line_contact(tmp_path):
    for radius in ("1e300", "1e9"):
        msg = error_of(broken(tmp_path, "radius2_x_mm = 27.075",
                              f"radius2_x_mm = 27.075\nradius2_y_mm = {radius}",
                              scene="paper_mpr"))
        assert "disc.radius2_y_mm" in msg and ("out of range" in msg or "line contact" in msg)


def test_toml_dates_are_named_as_dates(tmp_path):
    msg = error_of(broken(tmp_path, "module_mm = 3.95", "module_mm = 1979-05-27"))
    assert "gear.module_mm = 1979-05-27: expected a number, got a date or time" in msg


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


@pytest.mark.parametrize("where", ["after", "before"])
def test_cli_debug_shows_the_traceback(tmp_path, where):
    path = str(broken(tmp_path, "nu = 0.3", "nu = 0.7"))
    args = ("contact", path, "--debug") if where == "after" else ("--debug", "contact", path)
    out = run_cli(*args)
    assert out.returncode != 0 and "Traceback" in out.stderr and "SceneError" in out.stderr


def test_cli_unwritable_csv_is_a_plain_error(tmp_path):
    out = run_cli("contact", str(SCENES / "paper_mpr.toml"), "--csv", str(tmp_path))
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert out.stderr.startswith(f"micropit: error: cannot write --csv {tmp_path}: ")
    out = run_cli("check-env", "--expect-ranks", "0")
    assert out.returncode == 2 and "expected a positive whole number" in out.stderr


# ---- issue 30 item 4: the smaller faults ------------------------------------------------------
@pytest.mark.timeout(60)
def test_a_named_pipe_as_the_scene_is_refused_without_reading_it(tmp_path):
    """A FIFO used to block `micropit scene` for ever (the read waits for a writer)."""
    import os

    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    assert "is not a regular file (a named pipe)" in error_of(fifo)
    p = subprocess.run([sys.executable, "-m", "micropit_hpc", "scene", str(fifo)], cwd=ROOT,
                       capture_output=True, text=True, timeout=30)
    assert p.returncode == 2 and "named pipe" in p.stderr


@pytest.mark.parametrize("text, expect", [
    ('[study]\nname = "a"\nname = "b"\n', "key 'study.name' is given twice (again at line 3)"),
    ('[gear]\nmodule_mm = 3\n[body1]\nRq_um = 1\n[body1.surface]\ncorr_x_um = 3\n'
     'corr_x_um = 4\n', "key 'body1.surface.corr_x_um' is given twice (again at line 7)"),
    ('[study]\nname = "a"\n[study]\n', "table [study] is given twice (again at line 3)"),
    ('top = 1\ntop = 2\n', "key 'top' is given twice"),
])
def test_a_key_or_table_given_twice_is_named(tmp_path, text, expect):
    path = tmp_path / "dup.toml"
    path.write_text(text)
    assert expect in error_of(path)


@pytest.mark.parametrize("key", ["file", "dataset"])
def test_a_surface_file_for_a_body_whose_kind_ignores_it_is_an_error(tmp_path, key):
    path = broken(tmp_path, "corr_y_um = 100.0\n", f'corr_y_um = 100.0\n{key} = "flank.npy"\n')
    msg = error_of(path)
    assert f'body1.surface.{key} = "flank.npy"' in msg and 'kind is "gaussian"' in msg


def test_lengths_that_look_like_metres_are_warned_about(tmp_path):
    from micropit_hpc.plan import make_plan

    path = broken(tmp_path, "corr_x_um = 30.0", "corr_x_um = 3e-5")
    scene = load_scene(path)
    assert any("body1.surface.corr_x_um = 3e-05 looks like a value in metres" in w
               for w in scene.warnings), scene.warnings
    plan = make_plan(scene)
    assert any("body1.surface.corr_x_um = 3e-05 µm is shorter than one grid cell along x" in w
               for w in plan.warnings), plan.warnings
    assert not make_plan(load_scene(SCENES / "paper_gear_z23.toml")).warnings


def test_a_load_no_steel_carries_is_warned_about(tmp_path):
    """torque_Nm = 251000 (N·mm written as N·m) gives p0 = 34 GPa."""
    from micropit_hpc.plan import make_plan

    plan = make_plan(load_scene(broken(tmp_path, "torque_Nm = 251.0", "torque_Nm = 251000",
                                       scene="quick")))
    w = [w for w in plan.warnings if "above what any steel carries" in w]
    assert len(w) == 1 and "p0 = 34.3 GPa" in w[0] and "gear.torque_Nm = 251000" in w[0]
    p = subprocess.run([sys.executable, "-m", "micropit_hpc", "scene",
                        str(tmp_path / "bad.toml")], cwd=ROOT, capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0 and "p0 = 34.3 GPa" in p.stderr


def test_the_default_surfaces_fit_the_default_window(tmp_path):
    """A gear scene that leaves β_y at its default is not told that its window does not hold
    the roughness (the default was 300 µm: every such scene warned)."""
    from micropit_hpc.plan import make_plan

    text = (SCENES / "quick.toml").read_text().replace("corr_y_um = 150.0\n", "")
    path = tmp_path / "default_beta.toml"
    path.write_text(text)
    scene = load_scene(path)
    assert scene.body1.surface.corr_y == scene.body2.surface.corr_y == pytest.approx(90e-6)
    plan = make_plan(scene)
    assert plan.window_problems == () and plan.warnings == ()


def test_no_shipped_scene_relies_on_the_default_correlation_lengths():
    """The shipped scenes give β_x and β_y of every Gaussian surface themselves, so a change
    of the defaults does not change their results."""
    import tomllib

    for path in sorted(SCENES.glob("*.toml")):
        doc = tomllib.loads(path.read_text())
        for body in ("body1", "body2"):
            surface = doc[body].get("surface", {})
            if surface.get("kind", "gaussian") == "gaussian" and doc[body].get("Rq_um", 1):
                assert {"corr_x_um", "corr_y_um"} <= set(surface), (path.name, body)
