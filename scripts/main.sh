#!/usr/bin/env bash
# One command: set up what is missing, then run the main job (the default scene on 2 ranks).
# Usage: scripts/main.sh [SCENE] ; NP=4 scripts/main.sh for more ranks.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
export MICROPIT_PYTHON=${MICROPIT_PYTHON:-$(bash scripts/setup.sh)}
exec bash jobs/local.sh "${1:-scenes/quick.toml}"
