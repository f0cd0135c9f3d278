"""Optional PETSc: the package works without petsc4py; with it, options, stages and events."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest

from micropit_hpc.errors import MicropitError
from micropit_hpc.parallel import petsc

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def fresh(monkeypatch):
    """The module's state as before any init_petsc() (restored after the test)."""
    monkeypatch.setattr(petsc, "_PETSc", None)
    monkeypatch.setattr(petsc, "_fallback", {})
    monkeypatch.setattr(petsc, "_queried", set())
    monkeypatch.setattr(petsc, "_stages", {})
    monkeypatch.setattr(petsc, "_events", {})
    return petsc


@pytest.fixture
def no_petsc(fresh, monkeypatch):
    """As if petsc4py were not installed."""
    monkeypatch.setitem(sys.modules, "petsc4py", None)
    monkeypatch.setitem(sys.modules, "petsc4py.PETSc", None)
    return fresh


def test_importing_the_module_does_not_start_petsc():
    code = ("import sys, micropit_hpc.parallel.petsc as p; "
            "print('petsc4py.PETSc' in sys.modules, p.petsc())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=60)
    assert out.stdout.split() == ["False", "None"], out.stderr


def test_without_petsc_everything_falls_back(no_petsc):
    argv = ["-micropit_level", "4", "-micropit_wear", "-2.5e-9", "-micropit_plots",
            "-micropit_name", "gear", "-micropit_off", "no", "-micropit_typo", "1"]
    assert no_petsc.init_petsc(argv) is False
    assert no_petsc.petsc() is None
    ran = []
    with no_petsc.stage("life"), no_petsc.event("fatigue"):
        ran.append(True)
    assert ran == [True] and no_petsc._stages == {} and no_petsc._events == {}
    assert no_petsc.option("micropit_level", 1) == 4
    assert no_petsc.option("-micropit_wear", 0.0) == -2.5e-9
    assert no_petsc.option("micropit_plots", False) is True
    assert no_petsc.option("micropit_off", True) is False
    assert no_petsc.option("micropit_name", "x", str) == "gear"
    assert no_petsc.option("micropit_missing", 7) == 7
    out = io.StringIO()
    assert no_petsc.options_left_warning(stream=out) == ["micropit_typo"]
    assert out.getvalue() == "warning: option -micropit_typo was given but never used " \
                             "(misspelt?)\n"


def test_a_bad_fallback_value_is_a_clear_error(no_petsc):
    no_petsc.init_petsc(["-micropit_level", "four"])
    with pytest.raises(MicropitError, match="option -micropit_level four: not a valid int"):
        no_petsc.option("micropit_level", 1)


def test_without_init_stages_and_events_do_nothing(fresh):
    with fresh.stage("a"), fresh.event("b"):
        pass
    assert fresh._stages == {} and fresh._events == {}


def test_events_are_registered_in_one_order_whatever_the_first_use():
    """-log_view matches an event over the ranks by its registration index: init_petsc
    registers the code's events in the order of EVENTS, so a rank that first meets the
    wear's events before the contact's (an item with wear first) numbers them alike."""
    pytest.importorskip("petsc4py")
    code = ("import micropit_hpc.parallel.petsc as p; p.init_petsc([]); "
            "e = p.event('implicit_wear'); e.__enter__(); e.__exit__(None, None, None); "
            "print(' '.join(str(p._events[n].id) for n in p.EVENTS))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    ids = [int(i) for i in out.stdout.split()]
    assert len(ids) == len(petsc.EVENTS), out.stderr
    assert ids == sorted(ids) and len(set(ids)) == len(ids)


def test_with_petsc_options_stages_and_events(fresh):
    pytest.importorskip("petsc4py")
    assert fresh.init_petsc(["-micropit_level", "4", "-micropit_tol", "1e-6",
                             "-micropit_plots", "-micropit_typo", "x"]) is True
    PETSc = fresh.petsc()
    assert PETSc is sys.modules["petsc4py.PETSc"]
    assert PETSc.Options().getInt("micropit_level") == 4  # in PETSc's own database
    assert fresh.option("micropit_level", 1) == 4
    assert fresh.option("micropit_tol", 0.1) == pytest.approx(1e-6)
    assert fresh.option("micropit_plots", False) is True
    assert fresh.option("micropit_absent", "dflt") == "dflt"
    if not PETSc.Log.isActive():
        PETSc.Log.begin()  # performance counters need logging on
    for _ in range(2):
        with fresh.stage("life"), fresh.event("fatigue"):
            pass
    with fresh.event("fatigue"):
        pass
    life, fatigue = fresh._stages["life"], fresh._events["fatigue"]
    assert len(fresh._stages) == 1  # cached by name
    assert list(fresh._events) == [*fresh.EVENTS, "fatigue"]
    assert fatigue.getPerfInfo(life.id)["count"] == 2  # inside the stage
    assert fatigue.getPerfInfo()["count"] == 1  # outside it: stages were popped
    out = io.StringIO()
    assert fresh.options_left_warning(stream=out) == ["micropit_typo"]
    assert "-micropit_typo" in out.getvalue()
