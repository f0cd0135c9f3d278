"""The commit recorded in results files: dirty only when the package source changed."""

from __future__ import annotations

import shutil
import subprocess

import pytest

from micropit_hpc import describe_source

pytestmark = pytest.mark.skipif(shutil.which("git") is None, reason="needs git")


def _git(repo, *args):
    subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=repo,
                   check=True, capture_output=True)


def test_only_changes_inside_the_package_make_the_commit_dirty(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("x = 1\n")
    (tmp_path / "README.md").write_text("text\n")
    _git(tmp_path, "init", "-q")
    _git(tmp_path, "add", ".")
    _git(tmp_path, "commit", "-q", "-m", "one")
    head = subprocess.run(["git", "rev-parse", "--short=7", "HEAD"], cwd=tmp_path, text=True,
                          capture_output=True, check=True).stdout.strip()
    assert describe_source(pkg) == head
    (tmp_path / "README.md").write_text("edited\n")
    (pkg / "untracked.txt").write_text("scratch\n")
    assert describe_source(pkg) == head
    # the validation report asks about the whole checkout less its own output
    assert describe_source(tmp_path, (".", ":(exclude)README.md")) == head
    assert describe_source(tmp_path) == head + "-dirty"
    (pkg / "a.py").write_text("x = 2\n")
    assert describe_source(pkg) == head + "-dirty"


def test_outside_a_checkout_it_is_empty(tmp_path):
    assert describe_source(tmp_path) == ""
