"""FFTW plans measured once per machine and kept as wisdom (micropit_hpc.spectral, issue 31):
planned from the file in a fresh process, the same numbers as the reference transform, bitwise
the same in every process that reads the file."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from micropit_hpc import spectral

pytestmark = pytest.mark.skipif(not spectral.have_pyfftw(), reason="needs pyFFTW")

SHAPE = (40, 36)

#: A fresh process: plans SHAPE, convolves a fixed field and prints whether the plan came from
#: the wisdom file, the largest difference from numpy's transforms relative to the field's
#: largest value, and the result's bytes as hex (for the bitwise comparison).
CHILD = f"""
import numpy as np
from micropit_hpc.spectral import Grid, RealFFT2
g = Grid(*{SHAPE!r}, 1.0, 1.0)
f = np.random.default_rng(5).standard_normal(g.shape)
T = 1.0 / (1.0 + g.kappa)
plan = RealFFT2(g.shape)
got = plan.convolve(plan.interleaved(T), f).copy()
ref = np.fft.irfft2(np.fft.rfft2(f) * T, s=g.shape)
print(plan.from_wisdom, np.abs(got - ref).max() / np.abs(ref).max(), got.tobytes().hex())
"""


def _child(env):
    out = subprocess.run([sys.executable, "-c", CHILD], env={**os.environ, **env},
                         capture_output=True, text=True, check=True).stdout.split()
    return out[0] == "True", float(out[1]), out[2]


def test_plans_come_from_the_wisdom_file_once_it_holds_them(tmp_path):
    path = str(tmp_path / "sub" / "wisdom.txt")
    env = {"MICROPIT_FFTW_WISDOM": path, "MICROPIT_FFTW_PLANNER": "auto"}
    assert _child(env)[0] is False                # no file yet: ESTIMATE
    subprocess.run([sys.executable, "-m", "micropit_hpc.spectral", "plan",
                    f"{SHAPE[0]}x{SHAPE[1]}"], env={**os.environ, **env}, check=True,
                   capture_output=True)
    assert os.path.getsize(path) > 0
    first, second = _child(env), _child(env)
    # a sum of n terms, each within a few ulp: the FFT's rounding bound ~ ε log2 n
    bound = 50 * np.finfo(float).eps * np.log2(SHAPE[0] * SHAPE[1])
    assert first[0] and second[0]
    assert first[1] <= bound
    assert first[2] == second[2]                  # the same plan in both processes
    assert _child({**env, "MICROPIT_FFTW_PLANNER": "estimate"})[0] is False
    assert _child({"MICROPIT_FFTW_WISDOM": str(tmp_path / "none.txt"),
                   "MICROPIT_FFTW_PLANNER": "auto"})[0] is False


def test_wisdom_path_is_per_machine_and_can_be_given(monkeypatch, tmp_path):
    monkeypatch.delenv("MICROPIT_FFTW_WISDOM", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    path = spectral.wisdom_path()
    assert path.startswith(str(tmp_path / "micropit_hpc" / "fftw-wisdom-"))
    monkeypatch.setenv("MICROPIT_FFTW_WISDOM", "/x/w.txt")
    assert spectral.wisdom_path() == "/x/w.txt"
    monkeypatch.setenv("MICROPIT_FFTW_PLANNER", "fast")
    with pytest.raises(spectral.MicropitError, match="allowed auto"):
        spectral.planner_flag()


def _batch_planned(env) -> bool:
    code = ("from micropit_hpc.spectral import RealFFT2\n"
            f"print(RealFFT2({SHAPE!r}, batch=6).from_wisdom)")
    out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                         capture_output=True, text=True, check=True).stdout.split()
    return out[0] == "True"


def test_plan_measures_the_six_plane_batches_of_the_stress_layers_too(tmp_path):
    size = f"{SHAPE[0]}x{SHAPE[1]}"
    only = {"MICROPIT_FFTW_WISDOM": str(tmp_path / "one.txt"), "MICROPIT_FFTW_PLANNER": "auto"}
    both = {**only, "MICROPIT_FFTW_WISDOM": str(tmp_path / "both.txt")}
    subprocess.run([sys.executable, "-m", "micropit_hpc.spectral", "plan", size, "--batch", "1"],
                   env={**os.environ, **only}, check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "micropit_hpc.spectral", "plan", size],
                   env={**os.environ, **both}, check=True, capture_output=True)
    assert _child(only)[0] and _child(both)[0]
    assert not _batch_planned(only)
    assert _batch_planned(both)
    bad = subprocess.run([sys.executable, "-m", "micropit_hpc.spectral", "plan", size,
                          "--batch", "0"], env={**os.environ, **only}, capture_output=True,
                         text=True)
    assert bad.returncode == 2 and "--batch 0" in bad.stderr
