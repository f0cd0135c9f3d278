#!/usr/bin/env bash
# The MPR triple-disc validation of the paper (trends 1 and 7, docs/validation/README.md), on NP ranks
# (default 2): runs scenes/paper_mpr.toml (|S| = 0.05, 0.15, 0.30 to 10 M cycles) and
# scenes/paper_mpr_table9.toml (Λ scaling with and without wear), and the same two with the
# surfaces' correlation length along rolling doubled (scenes/*_beta30.toml: the paper's maps
# are not public, so this is the sensitivity to that unknown, not a fit); writes the
# side-by-side tables next to the results in runs/<scene>/ and prints the trend verdicts.
# Each scene runs as written (the converged default: adaptive blocks, implicit wear) into
# runs/<scene>/ and, unless PAPER=0, its literal twin (the paper's numerics,
# `life.integration = "paper"`, from scripts/paper-scene.sh) into runs/<scene>_paper/
# (PAPER_ONLY=1: only the twins). The twins take 1.6–3.4 min each on 2 ranks; the scenes as
# written with wear at 128² take hours (docs/validation/findings.md).
# PY=/path/to/python skips scripts/setup.sh. RESUME=1 goes on from each run's checkpoints
# (scripts/validate-run.sh).
# Exit status 1 if a trend fails on a scene as written (the twins' verdicts are only printed).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=${PY:-$(bash scripts/setup.sh)}
source scripts/mpi-env.sh
status=0
runs=()
for name in ${SCENES:-paper_mpr paper_mpr_beta30 paper_mpr_table9 paper_mpr_table9_beta30}; do
    [ -n "${PAPER_ONLY:-}" ] || runs+=("$name:scenes/$name.toml")
done
if [ "${PAPER:-1}" != 0 ]; then
    for name in ${SCENES:-paper_mpr paper_mpr_beta30 paper_mpr_table9 paper_mpr_table9_beta30}; do
        runs+=("${name}_paper:$(bash scripts/paper-scene.sh "$name")")
    done
fi
for entry in "${runs[@]}"; do
    name=${entry%%:*}
    scene=${entry#*:}
    PY=$py bash scripts/validate-run.sh "$name" "$scene"
    case "$name" in
        *table9*) which=table9; echo "== $name: A_p against Λ (trend 7)" ;;
        *)        which=mpr; echo "== $name: A_p against |S| (trend 1)" ;;
    esac
    # the trends are judged on the converged default; a twin's verdicts are printed beside them
    "$py" postprocess/paper_mpr.py "$which" "runs/$name" || [[ "$name" == *_paper ]] || status=1
    "$py" postprocess/plot_life.py "runs/$name" --out "runs/$name/life.png"
done
exit $status
