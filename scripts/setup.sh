#!/usr/bin/env bash
# Sets up whatever is missing for micropit_hpc, and nothing else. Idempotent; when everything is
# already there it only checks (well under 10 s). Prints the Python interpreter to use on stdout.
#
# Knobs (environment variables; docs/install.md):
#   MICROPIT_PYTHON=/path/to/python  use an existing environment (cluster modules, your own venv):
#                                    no apt-get, no .venv; micropit_hpc is installed into it editable
#   MICROPIT_NO_APT=1                never call apt-get; list the missing Debian packages and stop
#   MICROPIT_DEV=0                   skip the developer tools (ruff)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
say() { printf '[setup] %s\n' "$*" >&2; }
die() { printf '[setup] error: %s\n' "$*" >&2; exit 1; }

# Debian 12's consistent MPI stack (docs/install.md): Open MPI 4.1, mpi4py 3.1, parallel HDF5 h5py,
# PETSc 3.18, pyFFTW, mpi4py-fft, NumPy 1.24, SciPy 1.10, and the test plugins; Numba 0.56 (built
# for Debian's NumPy) for the compiled Dang Van kernel.
deb_pkgs=(python3-venv python3-pip python3-setuptools python3-wheel openmpi-bin
          python3-numpy python3-scipy python3-matplotlib python3-mpi4py python3-h5py-mpi
          python3-petsc4py python3-pyfftw python3-mpi4py-fft
          python3-pytest python3-pytest-mpi python3-pytest-timeout python3-numba)
# Of those, the ones the code runs without (more slowly): where they are missing and cannot be
# installed, setup says so and goes on (docs/install.md, "Numba").
deb_optional=(python3-numba)
ruff_pin="ruff==0.8.6"

if [[ -n "${MICROPIT_PYTHON:-}" ]]; then
    py=$MICROPIT_PYTHON
    command -v "$py" >/dev/null || die "MICROPIT_PYTHON=$py is not an executable"
    stamp="$root/.micropit-setup-stamp"
else
    command -v dpkg-query >/dev/null || die "no dpkg-query: this is not a Debian system; set MICROPIT_PYTHON to an environment that has mpi4py, h5py (mpio), petsc4py, pyfftw (docs/install.md)"
    mapfile -t missing < <(dpkg-query -W -f='${db:Status-Abbrev} ${Package}\n' "${deb_pkgs[@]}" 2>/dev/null \
                             | awk '$1 == "ii" {print $2}' | sort | comm -13 - <(printf '%s\n' "${deb_pkgs[@]}" | sort))
    required=() optional=()
    for p in "${missing[@]}"; do
        if [[ " ${deb_optional[*]} " == *" $p "* ]]; then optional+=("$p"); else required+=("$p"); fi
    done
    if ((${#missing[@]})); then
        if [[ "${MICROPIT_NO_APT:-0}" == 1 || $(id -u) -ne 0 ]]; then
            ((${#required[@]} == 0)) || die "missing Debian packages: ${required[*]} -- install them as root (apt-get install ${missing[*]}) or set MICROPIT_PYTHON (docs/install.md)"
            say "optional Debian packages missing: ${optional[*]} -- the code runs without them, more slowly (apt-get install ${optional[*]}; docs/install.md)"
        else
            say "installing ${#missing[@]} Debian packages: ${missing[*]}"
            export DEBIAN_FRONTEND=noninteractive
            log=$(mktemp)
            if ! { apt-get update -qq && { ((${#required[@]} == 0)) || apt-get install -y -qq --no-install-recommends "${required[@]}"; }; } >"$log" 2>&1; then
                tail -n 30 "$log" >&2
                die "apt-get failed (full log: $log)"
            fi
            if ((${#optional[@]})) && ! apt-get install -y -qq --no-install-recommends "${optional[@]}" >>"$log" 2>&1; then
                say "could not install the optional ${optional[*]} (log: $log); the code runs without them, more slowly"
            else
                rm -f "$log"
            fi
        fi
    fi
    if [[ ! -x .venv/bin/python ]]; then
        say "creating .venv (system site packages visible)"
        /usr/bin/python3 -m venv --system-site-packages .venv
    fi
    py="$root/.venv/bin/python"
    # Trap 3: petsc4py lives under PETSC_DIR; Debian's own .pth points at /usr/lib/petsc, which
    # only petsc-dev creates. Point the venv at the installed PETSc instead.
    petsc_dir=$(ls -d /usr/lib/petscdir/petsc*/*-linux-gnu-real 2>/dev/null | sort -V | tail -n 1 || true)
    [[ -n "$petsc_dir" ]] || die "python3-petsc4py is installed but no /usr/lib/petscdir/petsc*/*-linux-gnu-real was found"
    site=$(echo .venv/lib/python3*/site-packages)
    pth="$site/micropit-petsc4py.pth"
    want="$petsc_dir/lib/python3/dist-packages"
    [[ -f "$pth" && "$(cat "$pth")" == "$want" ]] || { echo "$want" > "$pth"; say "petsc4py path: $want"; }
    # Trap 1/2 for every later pip call in the venv, typed by hand too: the venv's own pip
    # configuration applies constraints.txt, so no install can replace Debian's NumPy, SciPy,
    # h5py (mpio) or mpi4py (docs/install.md, "Measured surfaces").
    conf=".venv/pip.conf"
    want_conf=$(printf '[install]\nconstraint = %s/constraints.txt\n' "$root")
    [[ -f "$conf" && "$(cat "$conf")" == "$want_conf" ]] || { printf '%s\n' "$want_conf" > "$conf"; say "pip in .venv now applies constraints.txt ($conf)"; }
    stamp="$root/.venv/.micropit-setup-stamp"
fi

dev=${MICROPIT_DEV:-1}
want_stamp="$( (cat pyproject.toml setup.cfg constraints.txt; echo "$py dev=$dev") | sha256sum | cut -d' ' -f1)"
if [[ -f "$stamp" && "$(cat "$stamp")" == "$want_stamp" ]] && "$py" -c 'import micropit_hpc' 2>/dev/null; then
    echo "$py"
    exit 0
fi
say "installing micropit_hpc (editable, no dependencies pulled by pip)"
"$py" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -c constraints.txt -e . >&2
if [[ "$dev" == 1 ]]; then
    "$py" -m pip install -q --disable-pip-version-check --no-deps -c constraints.txt "$ruff_pin" >&2
fi
echo "$want_stamp" > "$stamp"
echo "$py"
