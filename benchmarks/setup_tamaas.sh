#!/usr/bin/env bash
# A virtual environment of its own with Tamaas 2.9 from PyPI, for benchmarks/bench_vs_tamaas.py
# only. It is kept apart from .venv: Tamaas's wheel brings NumPy 2, which would break the Debian
# MPI stack there (docs/install.md, trap 4). Prints the interpreter to use.
#
#   bash benchmarks/setup_tamaas.sh          # TAMAAS_VENV=.venv-tamaas, TAMAAS_VERSION=2.9.0
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${TAMAAS_VENV:-$root/.venv-tamaas}
version=${TAMAAS_VERSION:-2.9.0}
if [[ ! -x "$venv/bin/python" ]]; then
    /usr/bin/python3 -m venv "$venv" >&2
fi
if ! "$venv/bin/python" -c "import tamaas, sys; sys.exit(tamaas.__version__ != '$version')" 2>/dev/null; then
    "$venv/bin/python" -m pip install -q "tamaas==$version" >&2
fi
echo "$venv/bin/python"
