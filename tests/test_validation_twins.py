"""The paper scenes and their literal twins (docs/life.md, "Two time integrations"): every
scenes/paper_*.toml runs the converged default (adaptive blocks, implicit wear);
scripts/paper-scene.sh writes its twin, the same scene with ``life.integration = "paper"`` and
nothing else changed, and refuses a scene it cannot make one from; the validation report
(postprocess/validation_report.py) decides each trend on the default runs and gives the twin's
verdict beside it, a missing twin said to be missing. The report is checked on fake MPR run
folders (summary.csv only; the gear runs are missing)."""

from __future__ import annotations

import csv
import dataclasses
import importlib.util
import os
import shutil
import subprocess

import numpy as np
import pytest
from helpers import ROOT, SCENES, read_table

from micropit_hpc.scene import load_scene
from micropit_hpc.study import SUMMARY_COLUMNS
from micropit_hpc.trends import Verdict

PAPER_SCENES = sorted(p.stem for p in SCENES.glob("paper_*.toml"))

_spec = importlib.util.spec_from_file_location(
    "validation_report", ROOT / "postprocess" / "validation_report.py")
report = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(report)


def test_there_are_paper_scenes():
    assert {"paper_mpr", "paper_gear_z23", "paper_gear_z18"} <= set(PAPER_SCENES)
    assert set(report.MPR_SCENES + report.GEAR_SCENES) == set(PAPER_SCENES)


@pytest.mark.parametrize("name", PAPER_SCENES)
def test_the_paper_scenes_run_the_converged_default(name):
    """The project's prediction: adaptive blocks with the implicit wear, written out in the
    line that scripts/paper-scene.sh changes."""
    scene = load_scene(SCENES / f"{name}.toml")
    assert (scene.life.integration, scene.life.wear_integration) == ("adaptive", "implicit")
    lines = (SCENES / f"{name}.toml").read_text().splitlines()
    assert lines.count('integration = "adaptive"') == 1
    assert not any(line.startswith("wear_integration") for line in lines)


def _script_root(tmp_path):
    """A copy of scripts/paper-scene.sh and the scenes in a root of their own (the script
    writes under its root's runs/scenes/)."""
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "paper-scene.sh", tmp_path / "scripts")
    shutil.copytree(SCENES, tmp_path / "scenes")
    return tmp_path


def _paper_scene(root, name):
    return subprocess.run(["bash", str(root / "scripts" / "paper-scene.sh"), name],
                          capture_output=True, text=True, cwd=root, timeout=30)


@pytest.mark.parametrize("name", PAPER_SCENES)
def test_the_twin_is_the_scene_in_the_papers_numerics(tmp_path, name):
    """runs/scenes/<name>_paper.toml loads, runs `paper` (whose wear is the explicit ΔN·Δh
    whatever wear_integration says, micropit_hpc.life.run_block) with the paper's pointwise
    criterion (the default process length of `paper`), and equals the scene in everything
    else."""
    root = _script_root(tmp_path)
    out = _paper_scene(root, name)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == f"runs/scenes/{name}_paper.toml"
    twin = load_scene(root / out.stdout.strip())
    scene = load_scene(SCENES / f"{name}.toml")
    assert twin.life.integration == "paper"
    assert twin.life != scene.life
    # the one key changes the criterion's default length too: pointwise, as the paper
    assert (twin.fatigue.process_length, scene.fatigue.process_length) == (0.0, 5.0 * 1e-6)
    assert dataclasses.replace(twin, source=scene.source, life=dataclasses.replace(
        twin.life, integration="adaptive"), fatigue=scene.fatigue) == scene
    assert twin.name == scene.name


@pytest.mark.parametrize("text,why", [
    ('integration = "paper"', "has no 'integration = \"adaptive\"' line"),
    ("", "has no 'integration = \"adaptive\"' line"),
    (None, "no scene file"),
])
def test_paper_scene_refuses_a_scene_without_the_line(tmp_path, text, why):
    root = _script_root(tmp_path)
    path = root / "scenes" / "other.toml"
    if text is not None:
        path.write_text((SCENES / "paper_mpr.toml").read_text().replace(
            'integration = "adaptive"', text))
    out = _paper_scene(root, "other")
    assert out.returncode == 1 and out.stdout == ""
    assert out.stderr.startswith("paper-scene: ") and str(path) in out.stderr
    assert why in out.stderr
    assert not (root / "runs" / "scenes" / "other_paper.toml").exists()


# ---- the report: the default decides, the twin beside it ----------------------------------------
def _summary(run, rows):
    """summary.csv of a run from (S, Lambda, k_lub, cycles, A_p of the roller), every column
    there (flags `none`)."""
    run.mkdir(parents=True, exist_ok=True)
    with open(run / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, SUMMARY_COLUMNS, restval="0")
        w.writeheader()
        for i, (s, lam, k, n, ap) in enumerate(rows):
            for body in (1, 2):
                w.writerow({"item": i, "position": 1, "S": s, "p0_GPa": 1.1, "Lambda": lam,
                            "k_lub_s": k, "body": body, "cycles": n, "Ap_pct": ap,
                            "flags": "none"})
    return run


def _mpr(ap_6m, ap_10m):
    """Rows of an MPR run: the roller's A_p at |S| = 0.05, 0.15, 0.30, 6 M and 10 M."""
    return [(-s, 0.176, 0.0, n, a) for n, aps in ((6e6, ap_6m), (10e6, ap_10m))
            for s, a in zip((0.05, 0.15, 0.3), aps, strict=True)]


def _table9(k0, k1):
    lams = (0.1762, 0.2468, 0.3091)
    return ([(0.3, lam, 0.0, 6e6, a) for lam, a in zip(lams, k0, strict=True)]
            + [(0.3, lam, 1e-11, 6e6, a) for lam, a in zip(lams, k1, strict=True)])


def _model():
    m = {(float(r["abs_S"]), float(r["cycles_million"])): float(r["Ap_model_pct"])
         for r in read_table("mpr_triple_disc_Ap.csv")}
    return ([m[(s, 6.0)] for s in (0.05, 0.15, 0.3)],
            [m[(s, 10.0)] for s in (0.05, 0.15, 0.3)])


def _fake_runs(runs, suffix, good: bool):
    """The four MPR runs of one scheme: trend 1 and 7 hold (the paper's model, its Table 9)
    when ``good``, and fail (A_p falls with sliding; no rise as Λ falls) otherwise."""
    six, ten = _model()
    k0, k1 = [7.19, 2.78, 0.24], [0.073, 0.080, 0.056]
    if not good:
        six, ten, k0 = six[::-1], ten[::-1], k0[::-1]
    for base in ("paper_mpr", "paper_mpr_beta30"):
        _summary(runs / f"{base}{suffix}", _mpr(six, ten))
    for base in ("paper_mpr_table9", "paper_mpr_table9_beta30"):
        _summary(runs / f"{base}{suffix}", _table9(k0, k1))


def _report(tmp_path) -> tuple[int, str]:
    rc = report.main(["--runs", str(tmp_path / "runs"), "--out", str(tmp_path / "out")])
    return rc, (tmp_path / "out" / "README.md").read_text()


def _trend_line(text, t):
    return next(line for line in text.splitlines() if line.startswith(f"* **trend {t}:"))


@pytest.mark.parametrize("default_good", [True, False])
def test_the_report_decides_on_the_default_and_gives_the_twin_beside_it(tmp_path,
                                                                        default_good):
    runs = tmp_path / "runs"
    _fake_runs(runs, "", default_good)
    _fake_runs(runs, "_paper", not default_good)
    rc, text = _report(tmp_path)
    assert rc == 1                                  # the gear runs are missing
    mine, twin = ("PASS", "FAIL") if default_good else ("FAIL", "PASS")
    for t in (1, 7):
        assert _trend_line(text, t).startswith(
            f"* **trend {t}: {mine}** (converged default; the paper's literal numerics: {twin})")
    lines = text.splitlines()
    at = lines.index(_trend_line(text, 1))
    assert lines[at + 1].startswith("  Converged default: paper_mpr: ")
    assert lines[at + 2].startswith("  Paper's literal numerics (`_paper` twin): "
                                    "paper_mpr_paper: ")
    # the gear runs of both schemes are missing: both are said to be missing (not to fail), and
    # the validation does not pass (rc 1 above)
    assert _trend_line(text, 2).startswith(
        "* **trend 2: missing** (converged default; the paper's literal numerics: missing)")
    assert "# Results in the converged default" in text
    assert "# Results in the paper's literal numerics (the `_paper` twins)" in text
    assert (tmp_path / "out" / "paper_mpr_mpr_comparison.csv").is_file()
    assert (tmp_path / "out" / "paper_mpr_paper_mpr_comparison.csv").is_file()


def _row(text, name):
    return next(line for line in text.splitlines() if line.startswith(f"| {name} |"))


def test_the_runs_table_gives_each_runs_process_length():
    """The report reads the criterion's ℓ that a run's results recorded, or (results older than
    that record) from the scene document they carry: the default's 5 µm for a paper scene as
    written, the pointwise 0 for its literal twin, a length the scene names as named, and "?"
    for a document that no longer loads."""
    import json
    import tomllib

    doc = tomllib.loads((SCENES / "paper_mpr.toml").read_text())
    assert report._process_length_um(json.dumps(doc)) == "5"
    doc["life"]["integration"] = "paper"
    assert report._process_length_um(json.dumps(doc)) == "0"
    doc["fatigue"] = {"process_length_um": 10.0}
    assert report._process_length_um(json.dumps(doc)) == "10"
    assert report._process_length_um(json.dumps({"study": {}})) == "?"
    # the length the results recorded wins over the document (a default may change later)
    assert report._process_length_um(json.dumps(doc), 0.0) == "0"
    assert report._process_length_um(json.dumps({"study": {}}), 5e-6) == "5"


def test_missing_twins_are_said_to_be_missing(tmp_path):
    _fake_runs(tmp_path / "runs", "", True)
    rc, text = _report(tmp_path)
    assert rc == 1
    for t in (1, 7, 8):
        line = _trend_line(text, t)
        assert line.startswith(f"* **trend {t}: PASS** (converged default; the paper's "
                               "literal numerics: missing)"), line
    assert "Paper's literal numerics (`_paper` twin): run missing" in text
    for name in ("paper_mpr_paper", "paper_gear_z23_paper"):
        assert _row(text, name).split("|")[7].strip() == "missing"
    assert f"*Missing: {tmp_path / 'runs' / 'paper_mpr_paper'}/summary.csv.*" in text
    assert "trend 1: PASS (the paper's literal numerics: missing) — paper_mpr_beta30:" in text


def test_the_verdict_is_the_defaults():
    """Every trend passing on the default passes the validation whatever the twin says; one
    failing on the default fails it whatever the twin says."""
    good = [Verdict(t, True, f"paper_mpr: ok {t}") for t in range(1, 9)]
    bad_twin = [Verdict(t, False, f"paper_mpr_paper: no {t}") for t in range(1, 9)]
    lines, passed = report.trend_lines(good, bad_twin)
    assert passed and sum("**" in line and ": PASS**" in line for line in lines) == 8
    assert all("numerics: FAIL)" in line for line in lines if line.startswith("* **"))
    lines, passed = report.trend_lines([*good[:3], Verdict(4, False, "x"), *good[4:]], good)
    assert not passed and "* **trend 4: FAIL** (converged default; the paper's literal " \
                          "numerics: PASS)" in "\n".join(lines)
    lines, passed = report.trend_lines(good, [])
    assert passed and all("numerics: missing)" in line for line in lines
                          if line.startswith("* **"))
    # a default run not made is said to be missing, not to fail, and the validation does not pass
    lines, passed = report.trend_lines(
        [*good[:6], Verdict(7, False, "paper_mpr_table9: run missing"), good[7]], good)
    assert not passed and "* **trend 7: missing** (converged default; the paper's literal " \
                          "numerics: PASS)" in "\n".join(lines)


# ---- A_p against ΔN, both schemes ---------------------------------------------------------------
def _bench():
    spec = importlib.util.spec_from_file_location(
        "bench_block_scheme", ROOT / "benchmarks" / "bench_block_scheme.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class _Inline:
    """A process pool that runs each job at once (futures already done)."""

    def __init__(self, procs):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def submit(self, fn, *args):
        from concurrent.futures import Future
        f = Future()
        f.set_result(fn(*args))
        return f


def test_bench_block_scheme_covers_both_schemes_and_refuses_old_rows(tmp_path, capsys,
                                                                       monkeypatch):
    """Both integrations at ΔN ∈ {0.1, 0.25, 0.5, 1} M, k_lub 0 and 1e-11 s, for both cases
    (the runs faked), each row naming the wear integration that ran; a file of an earlier
    version, whose rows do not say it, is refused rather than taken for new rows."""
    bench = _bench()
    done = []

    def fake(case, integration, k_lub, block, n):
        done.append((case, integration, k_lub, block, n))
        return dict.fromkeys(bench.COLUMNS, 0) | {
            "case": case, "integration": integration, "k_lub_s": k_lub, "block_M": block,
            "n": n, "wear": "explicit" if integration == "paper" else "implicit"}

    monkeypatch.setattr(bench, "run_one", fake)
    monkeypatch.setattr(bench, "ProcessPoolExecutor", _Inline)
    assert bench.main(["--out", str(tmp_path)]) == 0
    with open(tmp_path / "block_scheme.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(done) == 32
    assert {(r["case"], r["integration"], r["wear"]) for r in rows} == {
        (c, "adaptive", "implicit") for c in ("gear3", "mpr")} | {
        (c, "paper", "explicit") for c in ("gear3", "mpr")}
    assert sorted({float(r["block_M"]) for r in rows}) == [0.1, 0.25, 0.5, 1.0]
    assert bench.main(["--out", str(tmp_path)]) == 0 and len(done) == 32    # nothing new
    old = tmp_path / "old" / "block_scheme.csv"
    old.parent.mkdir()
    old.write_text("case,integration,k_lub_s,block_M,n,cycles_M,Ap1_pct,Ap2_pct,wear1_um,"
                   "wear2_um,evaluations,wall_s,flags\n")
    with pytest.raises(SystemExit) as e:
        bench.main(["--out", str(old.parent)])
    assert e.value.code == 2 and len(done) == 32
    err = capsys.readouterr().err
    assert str(old) in err and "move it away" in err


# ---- resuming a validation run: only the code that began it goes on ----------------------------
NEEDS_GIT = pytest.mark.skipif(shutil.which("git") is None, reason="needs git")


def _run_root(tmp_path):
    """A git checkout of its own with scripts/validate-run.sh, a micropit_hpc/ and a stand-in
    for the Python (it records the arguments of `micropit run`), so the script's choice of
    --overwrite or --restart can be read without a real run."""
    (tmp_path / "scripts").mkdir()
    for name in ("validate-run.sh", "mpi-env.sh"):
        shutil.copy(ROOT / "scripts" / name, tmp_path / "scripts")
    (tmp_path / "micropit_hpc").mkdir()
    (tmp_path / "micropit_hpc" / "__init__.py").write_text("A = 1\n")
    py = tmp_path / "py.sh"
    py.write_text('#!/usr/bin/env bash\necho "$@" > "$(dirname "$0")/args.txt"\n')
    py.chmod(0o755)
    _git(tmp_path, "init", "-q")
    _commit(tmp_path)
    return tmp_path


def _git(root, *args):
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=root,
                   check=True, capture_output=True, timeout=30)


def _commit(root):
    _git(root, "add", "-A", "micropit_hpc", "scripts")
    _git(root, "commit", "-q", "-m", "code")


def _validate_run(root, resume):
    env = {**os.environ, "PY": str(root / "py.sh"), "NP": "1"}
    env.pop("RESUME", None)
    if resume:
        env["RESUME"] = "1"
    (root / "args.txt").unlink(missing_ok=True)
    out = subprocess.run(["bash", str(root / "scripts" / "validate-run.sh"), "one",
                          "scenes/one.toml"], capture_output=True, text=True, cwd=root,
                         env=env, timeout=120)
    args = (root / "args.txt").read_text().split() if (root / "args.txt").exists() else None
    return out, args


def _tree(root):
    return subprocess.run(["git", "rev-parse", "HEAD:micropit_hpc"], cwd=root, check=True,
                          capture_output=True, text=True).stdout.strip()


@NEEDS_GIT
def test_a_validation_run_resumes_only_under_the_code_that_began_it(tmp_path):
    root = _run_root(tmp_path)
    stamp = root / "runs" / ".validate" / "one.tree"
    out, args = _validate_run(root, resume=True)        # no run folder yet: afresh
    assert out.returncode == 0, out.stderr
    assert args[-1] == "--overwrite" and args[:5] == ["-m", "micropit_hpc", "run",
                                                      "scenes/one.toml", "--out"]
    assert stamp.read_text().strip() == _tree(root)
    (root / "runs" / "one").mkdir()                    # what the run would have made
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 0, out.stderr
    assert args[-1] == "--restart"
    out, args = _validate_run(root, resume=False)       # without RESUME: afresh, as before
    assert args[-1] == "--overwrite"

    (root / "micropit_hpc" / "__init__.py").write_text("A = 2\n")   # uncommitted change
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 3 and args is None
    assert "runs/one/" in out.stderr and "uncommitted" in out.stderr
    assert "afresh" in out.stderr
    _commit(root)                                       # committed: another tree
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 3 and args is None
    assert "the code changed" in out.stderr and _tree(root) in out.stderr

    out, args = _validate_run(root, resume=False)      # afresh under the new code, then on
    assert args[-1] == "--overwrite" and stamp.read_text().strip() == _tree(root)
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 0 and args[-1] == "--restart"
    manifest = root / "runs" / "one" / "manifest.json"  # finished: left as it is
    manifest.write_text('{\n "blocks": 3,\n "status": "done"\n}\n')
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 0 and args is None and "left as it is" in out.stdout
    manifest.write_text('{\n "blocks": 3,\n "status": "stopped"\n}\n')
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 0 and args[-1] == "--restart"

    stamp.unlink()                                      # begun by something else
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 3 and args is None and "no stamp" in out.stderr


@NEEDS_GIT
def test_a_run_begun_with_uncommitted_code_is_never_resumed(tmp_path):
    root = _run_root(tmp_path)
    (root / "micropit_hpc" / "__init__.py").write_text("A = 3\n")
    out, args = _validate_run(root, resume=False)
    assert out.returncode == 0 and args[-1] == "--overwrite"
    (root / "runs" / "one").mkdir()
    _commit(root)
    out, args = _validate_run(root, resume=True)
    assert out.returncode == 3 and args is None and "'uncommitted'" in out.stderr


# ---- the gear trends' sensitivity to the slope (scripts/slope-scene.sh, the report's table) ------
def _slope_scene(root, name, beta):
    return subprocess.run(["bash", str(root / "scripts" / "slope-scene.sh"), name, beta],
                          capture_output=True, text=True, cwd=root, timeout=30)


def test_the_slope_variant_is_the_gear_scene_with_both_surfaces_beta_x_changed(tmp_path):
    root = _script_root(tmp_path)
    shutil.copy(ROOT / "scripts" / "slope-scene.sh", root / "scripts")
    scene = load_scene(SCENES / "paper_gear_z23.toml")
    for beta, run in report.slope_runs(root / "runs"):
        if beta == report.SCENE_BETA_UM:
            assert run.name == "paper_gear_z23"
            # the µm → m conversion rounds once on either side: a few ulp apart at most
            for body in (scene.body1, scene.body2):
                assert body.surface.corr_x == pytest.approx(beta * 1e-6, rel=1e-15)
            continue
        out = _slope_scene(root, "paper_gear_z23", f"{beta:g}")
        assert out.returncode == 0, out.stderr
        path = root / out.stdout.strip()
        assert path.name == f"{run.name}.toml"        # the run folder validate.sh uses
        variant = load_scene(path)
        for body in (variant.body1, variant.body2):
            assert body.surface.corr_x == pytest.approx(beta * 1e-6, rel=1e-15)
        same = dataclasses.replace(
            variant, source=scene.source, document=scene.document, warnings=scene.warnings,
            **{name: dataclasses.replace(getattr(variant, name), surface=dataclasses.replace(
                getattr(variant, name).surface, corr_x=getattr(scene, name).surface.corr_x))
               for name in ("body1", "body2")})
        assert same == scene


@pytest.mark.parametrize("beta,why", [("0", "not a positive number"),
                                      ("-5", "not a positive number"),
                                      ("abc", "not a positive number")])
def test_slope_scene_refuses_a_beta_that_is_not_a_length(tmp_path, beta, why):
    root = _script_root(tmp_path)
    shutil.copy(ROOT / "scripts" / "slope-scene.sh", root / "scripts")
    out = _slope_scene(root, "paper_gear_z23", beta)
    assert out.returncode == 1 and out.stdout == "" and why in out.stderr
    assert f"'{beta}'" in out.stderr


def test_slope_scene_refuses_a_scene_without_one_corr_x_line_per_surface(tmp_path):
    root = _script_root(tmp_path)
    shutil.copy(ROOT / "scripts" / "slope-scene.sh", root / "scripts")
    text = (SCENES / "paper_gear_z23.toml").read_text()
    (root / "scenes" / "other.toml").write_text(text.replace("corr_x_um = 30.0\n", "", 1))
    out = _slope_scene(root, "other", "60")
    assert out.returncode == 1 and "has 1 'corr_x_um = ' lines, not 2" in out.stderr
    assert not (root / "runs" / "scenes" / "other_beta60.toml").exists()


def _flank_rows(scale_k5=1.0):
    """Flank rows (plot_flank.flank_table's keys the trends read) from the paper's Table 4,
    which passes trends 2–4; ``scale_k5`` multiplies k_lub = 5e-11 s's A_p."""
    region = {int(r["position"]): r["pair_region"]
              for r in read_table("table3_contact_conditions_z23.csv")}
    rows = []
    for r in read_table("table4_Ap_along_flank_z23.csv"):
        for k, col in ((0.0, "0"), (1e-11, "1e-11"), (5e-11, "5e-11")):
            f = scale_k5 if k == 5e-11 else 1.0
            rows.append({"position": int(r["position"]), "S": float(r["S"]),
                         "region": region[int(r["position"])], "k_lub_s": k,
                         "Ap1_pct": f * float(r[f"Ap_pct_klub{col}_driver"]),
                         "Ap2_pct": f * float(r[f"Ap_pct_klub{col}_driven"])})
    return rows


def _slope_summary(dq):
    """summary.csv rows of two blocks: Δq per (k_lub, body) at the last, other values before."""
    return [{"cycles": str(n), "k_lub_s": str(k), "body": str(body), "position": str(pos),
             "slope_dq": str(dq[(k, body)] + pos * 1e-3 if n == 3e6 else 9.0),
             "Ap_pct": str(10.0 * body + pos if n == 3e6 else 99.0)}
            for n in (1e6, 3e6) for k in (0.0, 1e-11, 5e-11) for body in (1, 2)
            for pos in (1, 2, 3)]


def test_the_slope_table_gives_each_beta_its_slopes_means_and_verdicts():
    dq = {(k, b): 0.2 * b + (0.0 if k == 0.0 else -0.1) for k in (0.0, 1e-11, 5e-11)
          for b in (1, 2)}
    ratios = {(5e-11, 1): 0.8, (5e-11, 2): 1.25}
    md = report.slope_table([(15.0, _flank_rows(), _slope_summary(dq), ratios),
                             (30.0, _flank_rows(scale_k5=3.0), _slope_summary(dq), ratios),
                             (60.0, None, None, None)])
    rows = [line for line in md if line.startswith("| ") and not line.startswith("| β_x")]
    first, scene, missing = (line.split(" | ") for line in rows)
    # the last block's mean over positions: Δq 0.2·body + 0.002, A_p 10·body + 2
    assert first[1:7] == ["0.202 / 0.402", "0.102 / 0.302", "0.8 / 1.25", "12 / 22",
                          "12 / 22", "12 / 22"]
    assert [c.strip(" |") for c in first[7:]] == ["PASS", "PASS", "PASS"]
    assert scene[0] == "| 30 (the scene's)"
    # k_lub = 5e-11 s three times higher: no longer the lowest, trend 4 fails
    assert [c.strip(" |") for c in scene[7:]] == ["PASS", "PASS", "FAIL"]
    assert missing[1] == "run missing"


def _wavy(n=32, amp=1e-6):
    x = np.arange(n)[:, None] * np.ones((1, n))
    return amp * np.sin(2 * np.pi * x / 8.0)


def test_the_runs_table_names_the_code_tree_that_began_each_run(tmp_path):
    (tmp_path / ".validate").mkdir()
    (tmp_path / ".validate" / "one.tree").write_text("7f9a7aa8ed6d9f01becbf60c58c586a12403a005\n")
    assert report._tree(tmp_path, "one") == "7f9a7aa"
    assert report._tree(tmp_path, "two") == "not recorded"


def test_the_slope_of_the_surface_left_in_place_ignores_the_pits():
    start = _wavy()
    pitted = np.zeros(start.shape, bool)
    assert report.pair_slope_ratio(start - 3e-6, pitted, start) == pytest.approx(1.0, rel=1e-12)
    assert report.pair_slope_ratio(0.5 * start, pitted, start) == pytest.approx(0.5, rel=1e-12)
    pitted[5, 7] = pitted[20, 3] = True
    end = 0.5 * start
    end[pitted] -= 40e-6                       # a pit's floor: no pair that touches it counts
    assert report.pair_slope_ratio(end, pitted, start) == pytest.approx(0.5, rel=1e-12)
    rough = end + np.where(pitted | np.roll(pitted, -1, axis=0), 0.0, 1e-7 * (-1.0) ** np.arange(
        32)[:, None])                          # ripple on the intact surface: steeper than 0.5
    assert report.pair_slope_ratio(rough, pitted, start) > 0.6
    near = np.zeros(start.shape, bool)
    near[:16] = True                           # only the pairs starting in the first half
    assert report.pair_slope_ratio(end, pitted, start, where=near) == pytest.approx(0.5,
                                                                                    rel=1e-12)
    assert np.isnan(report.pair_slope_ratio(end, pitted, start, where=pitted))
    assert np.isnan(report.pair_slope_ratio(end, np.ones_like(pitted), start))


class _FakeResults:
    """What pair_slope_ratios reads of a run's results: the items and their final maps."""

    def __init__(self, items, maps):
        self.items, self._maps = items, maps

    def maps(self, item, body, *names):
        return {n: self._maps[(item, body)][n] for n in names}


def test_each_item_is_held_against_the_start_of_its_own_surface():
    start = _wavy()
    pitted = np.zeros(start.shape, bool)
    pitted[3, 3] = True
    # items: (position 1, patch 0) at k_lub 0, 1e-11, 5e-11; (position 2, patch 0) at 0, 5e-11
    ids = np.arange(5)
    items = {"id": ids, "position": np.array([1, 1, 1, 2, 2]), "patch": np.zeros(5, int),
             "roughness_scale": np.ones(5), "k_lub": np.array([0, 1e-11, 5e-11, 0, 5e-11])}
    maps = {}
    for i, (pos, k) in enumerate(zip(items["position"], items["k_lub"], strict=True)):
        surf = start if pos == 1 else 2.0 * start       # each position its own start
        scale = {0.0: 1.0, 1e-11: 0.9, 5e-11: 0.6 if pos == 1 else 0.8}[float(k)]
        for body in (1, 2):
            pit_depth = np.where(pitted, 5e-6, 0.0) if k == 0 else np.zeros_like(start)
            maps[(i, body)] = {"heights": scale * surf - pit_depth, "pit_depth": pit_depth,
                               "pitted": pitted}
    r = report.pair_slope_ratios(_FakeResults(items, maps))
    assert r[(0.0, 1)] == pytest.approx(1.0, rel=1e-12)          # heights + pits = the start
    assert r[(1e-11, 2)] == pytest.approx(0.9, rel=1e-12)
    assert r[(5e-11, 1)] == pytest.approx(0.7, rel=1e-12)         # mean of 0.6 and 0.8
