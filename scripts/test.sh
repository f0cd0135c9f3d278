#!/usr/bin/env bash
# One command: set up what is missing, then run the whole test suite:
# lint (ruff), the serial tests, the compiled-kernel tests again for a generic x86-64 CPU from an
# empty Numba cache, then the MPI tests under `mpirun -n 2`.
# Extra arguments go to every pytest run (e.g. -x, -k gear, -m "not slow").
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=$(bash scripts/setup.sh)
source scripts/mpi-env.sh

if [[ "${MICROPIT_DEV:-1}" == 1 ]]; then
    echo "== ruff"
    "$py" -m ruff check --no-cache .
fi
echo "== serial tests"
"$py" -m pytest -p no:cacheprovider "$@"
# The compiled kernels are compiled for the CPU at hand, so a tolerance that depends on its
# vector width (AVX2 against AVX-512 summation orders) would fail on some machines only; once
# more for a generic x86-64 target, compiled from an empty cache, so such a tolerance fails here.
if "$py" -c "import numba" 2>/dev/null; then
    echo "== compiled-kernel tests, NUMBA_CPU_NAME=generic, empty Numba cache"
    cache=$(mktemp -d)
    rc=0
    NUMBA_CPU_NAME=generic NUMBA_CACHE_DIR=$cache "$py" -m pytest -p no:cacheprovider \
        tests/test_kernels.py tests/test_dangvan_numba.py tests/test_mixed.py "$@" || rc=$?
    rm -rf "$cache"
    ((rc == 0 || rc == 5)) || exit "$rc"      # 5: the extra arguments selected none of them
fi
echo "== MPI tests (mpirun -n 2)"
logs=$(mktemp -d)
status=0
mpirun -n 2 bash scripts/rank0-output.sh "$logs" "$py" -m pytest -p no:cacheprovider --with-mpi -m mpi "$@" || status=$?
if ((status)); then
    for f in "$logs"/rank*.log; do echo "---- $f"; cat "$f"; done
fi
rm -rf "$logs"
exit $status
