#!/usr/bin/env bash
# The validation against the paper's trends (docs/validation/README.md), on NP ranks (default 2): the MPR rig and its
# Λ scaling (scripts/validate-mpr.sh: scenes/paper_mpr*.toml), then the gear studies
# (scenes/paper_gear_z23.toml: Table 4; paper_gear_z23_table5.toml: Table 5;
# paper_gear_z23_table8.toml and paper_gear_z18.toml: Table 8), then the report
# docs/validation/README.md with the figures, our numbers beside the paper's and one PASS/FAIL
# line per trend (postprocess/validation_report.py). Runs go to runs/<scene>/.
# On 2 cores (2026-11-23, commit 3bb5ded, with tests running beside it): 89 min in all, the
# paper-scheme runs 14 min, the adaptive gear runs 15 min, the adaptive MPR runs 60 min.
# SCENES="..." picks MPR scenes; GEARS_ONLY=1 skips the MPR runs (their last results are reused).
# Every paper scene runs the paper's block scheme (its `life.integration = "paper"`); each is run
# a second time with `integration = "adaptive"` (runs/<scene>_adaptive/, from a copy of the scene
# with that one key changed), and the report gives both. ADAPTIVE=0 skips the adaptive runs
# (the report then says they are missing). The A_p-against-ΔN table comes from
# benchmarks/results/block_scheme.csv (benchmarks/bench_block_scheme.py) when it is there.
# Exit status 1 if a trend fails (the report is written either way).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=$(bash scripts/setup.sh)
source scripts/mpi-env.sh
np=${NP:-2}
t0=$(date +%s)
if [ -z "${GEARS_ONLY:-}" ]; then
    ADAPTIVE=0 bash scripts/validate-mpr.sh || true
fi
for name in paper_gear_z23 paper_gear_z23_table5 paper_gear_z23_table8 paper_gear_z18; do
    echo "== micropit run scenes/$name.toml on $np ranks"
    mpirun -n "$np" "$py" -m micropit_hpc run "scenes/$name.toml" --out "runs/$name" --overwrite
    "$py" postprocess/plot_flank.py "runs/$name"
done
if [ "${ADAPTIVE:-1}" != 0 ]; then
    for name in paper_gear_z23 paper_gear_z23_table5 paper_gear_z23_table8 paper_gear_z18; do
        scene=$(bash scripts/adaptive-scene.sh "$name")
        echo "== micropit run $scene (adaptive blocks) on $np ranks"
        mpirun -n "$np" "$py" -m micropit_hpc run "$scene" --out "runs/${name}_adaptive" --overwrite
        "$py" postprocess/plot_flank.py "runs/${name}_adaptive"
    done
    if [ -z "${GEARS_ONLY:-}" ]; then
        ADAPTIVE_ONLY=1 bash scripts/validate-mpr.sh || true
    fi
fi
status=0
"$py" postprocess/validation_report.py --runs runs --out docs/validation || status=1
echo "validation: $(( ($(date +%s) - t0) / 60 )) min on $np ranks; report docs/validation/README.md"
exit $status
