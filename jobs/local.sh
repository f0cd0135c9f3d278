#!/usr/bin/env bash
# Local launch on a workstation: check the environment, run the life simulation of a scene on
# NP ranks, then plot it.
#   bash jobs/local.sh [SCENE]        (default scenes/quick.toml; NP=2 by default)
# Environment:
#   NP=N               ranks (default 2)
#   OUT_DIR=DIR        output folder (default runs/<scene name>)
#   RESTART=1          continue from the checkpoint OUT_DIR/checkpoints/LATEST names
#   OVERWRITE=1|0      without RESTART=1: replace a previous run's results and checkpoints in
#                      OUT_DIR (default 1 here, said in the log: the example is meant to be run
#                      again); OVERWRITE=0 passes no --overwrite, so `micropit run` refuses a
#                      folder holding another run's files
#   RUN_ARGS="..."     more `micropit run` arguments (--ranks-per-item 2, --max-wall 1:00:00,
#                      -log_view, ...)
#   MICROPIT_PYTHON    the interpreter (default .venv/bin/python from scripts/setup.sh)
#   KILL_GRACE_S=S     seconds mpirun leaves the ranks to reach a block boundary when it is
#                      signalled itself (default 30; jobs/forward.sh)
# Exit code 85: the run stopped at a block boundary after writing a checkpoint (SIGUSR1 or
# SIGTERM to this script, to mpirun or to the whole process group, or OUT_DIR/STOP); run again
# with RESTART=1 to continue.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
source scripts/mpi-env.sh
py=${MICROPIT_PYTHON:-$root/.venv/bin/python}
np=${NP:-2}
scene=${1:-scenes/quick.toml}
name=$(basename "$scene" .toml)
out=${OUT_DIR:-runs/$name}
mkdir -p "$out"

echo "== micropit check-env on $np ranks"
mpirun -n "$np" "$py" -m micropit_hpc check-env --expect-ranks "$np"
args=(run "$scene" --out "$out" --stop-file "$out/STOP")
[[ "${RESTART:-0}" == 1 ]] && args+=(--restart)
if [[ "${RESTART:-0}" != 1 && "${OVERWRITE:-1}" == 1 ]]; then
    if [[ -e "$out/summary.csv" || -e "$out/results.h5" || -e "$out/checkpoints/LATEST" ]]; then
        echo "== $out holds a previous run: replacing it (--overwrite; OVERWRITE=0 refuses, RESTART=1 continues it)"
    fi
    args+=(--overwrite)
fi
# shellcheck disable=SC2206  # RUN_ARGS is split on purpose
[[ -z "${RUN_ARGS:-}" ]] || args+=(${RUN_ARGS})
echo "== micropit ${args[*]} on $np ranks"
# SIGTERM/SIGUSR1 to this script reach the ranks as SIGUSR1 through mpirun (jobs/forward.sh);
# either, or the same signal to the whole process group, ends in a checkpoint and exit 85.
EXIT_CHECKPOINTED=85  # micropit_hpc.parallel.control.EXIT_CHECKPOINTED
log() { echo "== $*"; }
source jobs/forward.sh
run_forwarding "" "$out" mpirun -n "$np" "$py" -m micropit_hpc "${args[@]}"
if ((rc == EXIT_CHECKPOINTED)); then
    echo "== stopped with a checkpoint (exit 85): RESTART=1 bash jobs/local.sh $scene continues"
    exit "$EXIT_CHECKPOINTED"
elif ((rc)); then
    exit "$rc"
fi
echo "== plots"
if "$py" - "$out" <<'PY'
import sys, h5py, numpy as np
with h5py.File(sys.argv[1] + "/results.h5", "r") as f:
    ok = "roll_angle" in f["items"] and not np.all(np.isnan(f["items/roll_angle"][()]))
sys.exit(0 if ok else 1)
PY
then
    "$py" postprocess/plot_flank.py "$out"
    what="$out/flank.png (A_p along the flank, Fig. 8 style) and $out/flank.csv"
else
    what="the A_p table $out/summary.csv"
fi
"$py" postprocess/plot_life.py "$out"
echo "== done: $what, $out/life.png (A_p against cycles and damage maps), all numbers in" \
     "$out/summary.csv and $out/results.h5 (docs/outputs.md)"
