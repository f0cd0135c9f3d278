#!/usr/bin/env bash
# The MPR triple-disc validation of the paper (trends 1 and 7, docs/validation/README.md), on NP ranks
# (default 2): runs scenes/paper_mpr.toml (|S| = 0.05, 0.15, 0.30 to 10 M cycles) and
# scenes/paper_mpr_table9.toml (Λ scaling with and without wear), and the same two with the
# surfaces' correlation length along rolling doubled (scenes/*_beta30.toml: the paper's maps
# are not public, so this is the sensitivity to that unknown, not a fit); writes the
# side-by-side tables next to the results in runs/<scene>/ and prints the trend verdicts.
# On 2 cores (2026-11-23): the four scenes 2.5 min each in the paper's scheme; adaptive
# paper_mpr 13 min, _beta30 4 min, paper_mpr_table9 33 min, _table9_beta30 10 min.
# Each scene runs as written (the paper's block scheme) and, unless ADAPTIVE=0, a second time
# with `life.integration = "adaptive"` into runs/<scene>_adaptive/ (ADAPTIVE_ONLY=1: only that).
# Exit status 1 if a trend fails.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=$(bash scripts/setup.sh)
source scripts/mpi-env.sh
np=${NP:-2}
status=0
runs=()
for name in ${SCENES:-paper_mpr paper_mpr_beta30 paper_mpr_table9 paper_mpr_table9_beta30}; do
    [ -n "${ADAPTIVE_ONLY:-}" ] || runs+=("$name:scenes/$name.toml")
done
if [ "${ADAPTIVE:-1}" != 0 ]; then
    for name in ${SCENES:-paper_mpr paper_mpr_beta30 paper_mpr_table9 paper_mpr_table9_beta30}; do
        runs+=("${name}_adaptive:$(bash scripts/adaptive-scene.sh "$name")")
    done
fi
for entry in "${runs[@]}"; do
    name=${entry%%:*}
    scene=${entry#*:}
    echo "== micropit run $scene on $np ranks"
    mpirun -n "$np" "$py" -m micropit_hpc run "$scene" --out "runs/$name" --overwrite
    case "$name" in
        *table9*) echo "== $name: A_p against Λ (trend 7)"
                  "$py" postprocess/paper_mpr.py table9 "runs/$name" || status=1 ;;
        *)        echo "== $name: A_p against |S| (trend 1)"
                  "$py" postprocess/paper_mpr.py mpr "runs/$name" || status=1 ;;
    esac
    "$py" postprocess/plot_life.py "runs/$name" --out "runs/$name/life.png"
done
exit $status
