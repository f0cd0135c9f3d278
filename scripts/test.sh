#!/usr/bin/env bash
# One command: set up what is missing, then run the whole test suite:
# lint (ruff), the serial tests, then the MPI tests under `mpirun -n 2`.
# Extra arguments go to both pytest runs (e.g. -x, -k gear).
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
echo "== MPI tests (mpirun -n 2)"
logs=$(mktemp -d)
status=0
mpirun -n 2 bash scripts/rank0-output.sh "$logs" "$py" -m pytest -p no:cacheprovider --with-mpi -m mpi "$@" || status=$?
if ((status)); then
    for f in "$logs"/rank*.log; do echo "---- $f"; cat "$f"; done
fi
rm -rf "$logs"
exit $status
