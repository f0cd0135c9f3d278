#!/usr/bin/env bash
# Local launch on a workstation: check the environment, then run the main job on NP ranks.
#   bash jobs/local.sh [SCENE]        (default scenes/gear_z23.toml; NP=2 by default)
# Environment: NP (ranks), OUT_DIR (default runs/<scene name>), MICROPIT_PYTHON (interpreter;
# default .venv/bin/python from scripts/setup.sh).
# For now the main job computes the contact conditions along the flank and plots them, then
# one time step of the rough contact at position POSITION (default 3); the life simulation will
# take its place when it lands.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
source scripts/mpi-env.sh
py=${MICROPIT_PYTHON:-$root/.venv/bin/python}
np=${NP:-2}
scene=${1:-scenes/gear_z23.toml}
name=$(basename "$scene" .toml)
out=${OUT_DIR:-runs/$name}
mkdir -p "$out"

echo "== micropit check-env on $np ranks"
mpirun -n "$np" "$py" -m micropit_hpc check-env --expect-ranks "$np"
echo "== micropit contact $scene on $np ranks"
mpirun -n "$np" "$py" -m micropit_hpc contact "$scene" --csv "$out/contact.csv"
"$py" postprocess/plot_contact.py "$scene" --out "$out/contact.png"
pos=${POSITION:-3}
echo "== micropit snapshot $scene, position $pos (one time step of the rough contact)"
"$py" -m micropit_hpc snapshot "$scene" --position "$pos" --out "$out/snapshot"
echo "== done: contact table $out/contact.csv, plot $out/contact.png, rough contact" \
     "$out/snapshot/snapshot.h5 and maps $out/snapshot/snapshot.png"
