#!/usr/bin/env bash
# Installs the optional SurfaceTopography reader (ISO 25178-72 .x3p, .sdf, .sur, .opd, .datx,
# .plu and other instrument formats) into the project's environment without replacing NumPy,
# SciPy, h5py or mpi4py (docs/install.md, "Measured surfaces"):
#   1. the extra [surfaces] (SurfaceTopography's own dependencies) under constraints.txt;
#   2. SurfaceTopography itself with --no-deps (its metadata asks for NumPy 2, which would
#      replace Debian's NumPy 1.24 and break every compiled Debian module);
#   3. a check that NumPy, SciPy, h5py and mpi4py are the same files as before and that a
#      map can be read.
# MICROPIT_PYTHON as for scripts/setup.sh; SURFACETOPOGRAPHY_VERSION (default 1.27.1, the
# version this was tested with).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
say() { printf '[install-surfaces] %s\n' "$*" >&2; }
py=${MICROPIT_PYTHON:-$root/.venv/bin/python}
[[ -x "$py" ]] || { say "error: no $py: run scripts/setup.sh first"; exit 1; }
version=${SURFACETOPOGRAPHY_VERSION:-1.27.1}
stack='import numpy, scipy, h5py, mpi4py; print(*(f"{m.__name__} {m.__version__} {m.__file__}" for m in (numpy, scipy, h5py, mpi4py)), sep="\n")'
before=$("$py" -c "$stack")
say "dependencies of SurfaceTopography (extra [surfaces]) under constraints.txt"
"$py" -m pip install -q --disable-pip-version-check --no-build-isolation -c constraints.txt -e ".[surfaces]"
say "SurfaceTopography $version without its dependencies"
"$py" -m pip install -q --disable-pip-version-check --no-deps -c constraints.txt "SurfaceTopography==$version"
after=$("$py" -c "$stack")
if [[ "$before" != "$after" ]]; then
    say "error: the MPI stack changed:"; diff <(echo "$before") <(echo "$after") >&2 || true
    exit 1
fi
"$py" - <<'PY'
import tempfile, pathlib
import numpy as np
import SurfaceTopography as st
from SurfaceTopography.IO.X3P import write_x3p
from micropit_hpc.surfaces import read_topography

with tempfile.TemporaryDirectory() as d:
    path = pathlib.Path(d) / "check.x3p"
    h = np.random.default_rng(0).normal(0.0, 0.5, (32, 24))
    write_x3p(st.Topography(h, physical_sizes=(32 * 0.8, 24 * 0.8), unit="µm"), str(path))
    t = read_topography(path)
    assert abs(t.dx - 0.8e-6) < 1e-15 and abs(t.rq - h.std() * 1e-6) < 1e-12 * t.rq
print(f"[install-surfaces] SurfaceTopography {st.__version__} reads .x3p; NumPy {np.__version__} kept")
PY
