"""The micropit command: contact table, scene check, key reference, documentation in sync."""

from __future__ import annotations

import csv
import io
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import ROOT, SCENES

from micropit_hpc.cli import main
from micropit_hpc.report import CONTACT_COLUMNS
from micropit_hpc.scene import keys_markdown


def run(*args):
    return subprocess.run([sys.executable, "-m", "micropit_hpc", *args], capture_output=True,
                          text=True, cwd=ROOT, timeout=120)


def test_contact_prints_the_path_summary_and_exactly_the_csv_columns(tmp_path):
    out = run("contact", "scenes/paper_gear_z23.toml", "--csv", str(tmp_path / "c.csv"))
    assert out.returncode == 0, out.stderr
    comments = [line for line in out.stdout.splitlines() if line.startswith("#")]
    for point in ("A", "B", "C", "D", "E"):
        assert any(line.startswith(f"#   {point} ") for line in comments), point
    assert any("eps_alpha = 1.2984" in line for line in comments)
    table = "\n".join(line for line in out.stdout.splitlines() if not line.startswith("#"))
    rows = list(csv.DictReader(io.StringIO(table)))
    assert tuple(rows[0]) == CONTACT_COLUMNS == (
        "position", "roll_angle_deg", "radial_pos_mm", "R_mm", "w_N_per_m", "p0_GPa", "b_um",
        "S", "u_mean_m_s", "hc_um", "Lambda", "region", "lambda_GF")
    assert len(rows) == 11 and {r["region"] for r in rows} == {"single", "double"}
    assert (tmp_path / "c.csv").read_text() == table + "\n"  # the file holds only the CSV


def test_disc_rows_leave_gear_only_columns_empty():
    out = run("contact", "scenes/paper_mpr.toml")
    rows = list(csv.DictReader(io.StringIO(
        "\n".join(line for line in out.stdout.splitlines() if not line.startswith("#")))))
    assert [float(r["S"]) for r in rows] == [0.05, 0.15, 0.3]
    assert all(r["roll_angle_deg"] == "" and r["radial_pos_mm"] == "" for r in rows)
    assert float(rows[0]["Lambda"]) == pytest.approx(37 / 210, rel=1e-4)   # paper: Λ ≈ 0.18
    assert float(rows[0]["b_um"]) == pytest.approx(94, rel=0.005)           # 4 R_x p0 / E'


def test_every_shipped_scene_is_valid(capsys):
    scenes = sorted(str(p) for p in SCENES.glob("*.toml"))
    assert len(scenes) >= 4
    assert main(["scene", *scenes]) == 0
    assert capsys.readouterr().out.count("valid scene") == len(scenes)


def test_key_reference_documents_every_key_and_docs_are_current(capsys):
    assert main(["scene", "--help-keys"]) == 0
    printed = capsys.readouterr().out
    assert printed.strip() == keys_markdown().strip()
    assert (ROOT / "docs" / "scenes.md").read_text().strip() == printed.strip(), (
        "docs/scenes.md is stale: regenerate with "
        "`micropit scene --help-keys > docs/scenes.md`")
    for name in ("module_mm", "torque_Nm", "E_star_GPa", "roll_angle_deg", "slide_roll",
                 "lambda_roughness", "accuracy_grade"):
        assert f"| `{name}` |" in printed


def test_entry_points():
    assert run("--version").stdout.startswith("micropit_hpc ")
    exe = Path(sys.executable).parent / "micropit"  # the console script of the install
    out = subprocess.run([str(exe), "scene", "scenes/paper_mpr.toml"], capture_output=True,
                         text=True, cwd=ROOT, timeout=60)
    assert out.returncode == 0 and "valid scene 'paper_mpr'" in out.stdout


@pytest.mark.parametrize("scene", ["paper_gear_z23", "paper_mpr"])
def test_contact_plot_is_written(tmp_path, scene):
    png = tmp_path / f"{scene}.png"
    out = subprocess.run([sys.executable, str(ROOT / "postprocess" / "plot_contact.py"),
                          str(SCENES / f"{scene}.toml"), "--out", str(png)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
