#!/usr/bin/env bash
# The validation against the paper's trends (docs/validation/README.md), on NP ranks (default 2): the MPR rig and its
# Λ scaling (scripts/validate-mpr.sh: scenes/paper_mpr*.toml), then the gear studies
# (scenes/paper_gear_z23.toml: Table 4; paper_gear_z23_table5.toml: Table 5;
# paper_gear_z23_table8.toml and paper_gear_z18.toml: Table 8), then the report
# docs/validation/README.md with the figures, our numbers beside the paper's and one PASS/FAIL
# line per trend (postprocess/validation_report.py). Runs go to runs/<scene>/.
# SCENES="..." picks MPR scenes; GEARS_ONLY=1 skips the MPR runs (their last results are reused).
# Every paper scene runs as written, the converged default (adaptive blocks with the implicit
# wear, `life.integration = "adaptive"`), which decides each trend; each is run a second time as
# its literal twin, the paper's numerics (`integration = "paper"`: fixed blocks of ΔN, one
# evaluation per block, explicit wear ΔN·Δh), into runs/<scene>_paper/ from the copy of the
# scene that scripts/paper-scene.sh writes with that one key changed, and the report gives it
# beside each trend. PAPER=0 skips the twins (the report then says they are missing);
# PAPER_ONLY=1 runs only the twins (the report reuses the last default runs). Run times on 2
# idle ranks of a 2-core machine (2026-12-02, commit b95c279): the gear scenes
# 14.6 + 1.5 + 1.1 + 1.2 min wall clock, the MPR scenes without wear 1.9 + 1 min, all twins
# 7 min, β_x = 60 and 120 µm 16 and 24 min: 68 min; the MPR scenes with wear (Table 9) at 128² and β_x = 15 µm
# were not run then (docs/validation/findings.md). β_x = 15 µm alone took 49.7 min on a slower machine
# (2026-12-03, about twice the scene's 30 µm on one machine: up to 125 steps per load cycle).
# The A_p-against-ΔN table comes from
# benchmarks/results/block_scheme.csv (benchmarks/bench_block_scheme.py) when it is there.
# Last, the gear trends' sensitivity to the unknown slope of the paper's flanks: scenes/
# paper_gear_z23.toml again with both surfaces' β_x (corr_x_um) set to each of SLOPES (default
# "15 60 120" µm, beside the scene's 30; SLOPES= skips them) by scripts/slope-scene.sh, into
# runs/paper_gear_z23_beta<B>/, converged default only; the report gives each β_x's verdicts.
# PY=/path/to/python skips scripts/setup.sh. RESUME=1 goes on from each run's checkpoints
# (scripts/validate-run.sh: a finished run is left as it is; a run begun by other code is
# refused), so the validation can be stopped at any time and resumed. REPORT=0: no report.
# Exit status 1 if a trend fails on the default runs (the report is written either way).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=${PY:-$(bash scripts/setup.sh)}
source scripts/mpi-env.sh
np=${NP:-2}
t0=$(date +%s)
if [ -z "${GEARS_ONLY:-}" ] && [ -z "${PAPER_ONLY:-}" ]; then
    PY=$py PAPER=0 bash scripts/validate-mpr.sh || true
fi
if [ -z "${PAPER_ONLY:-}" ]; then
    for name in paper_gear_z23 paper_gear_z23_table5 paper_gear_z23_table8 paper_gear_z18; do
        PY=$py bash scripts/validate-run.sh "$name" "scenes/$name.toml"
        "$py" postprocess/plot_flank.py "runs/$name"
    done
fi
if [ "${PAPER:-1}" != 0 ]; then
    for name in paper_gear_z23 paper_gear_z23_table5 paper_gear_z23_table8 paper_gear_z18; do
        scene=$(bash scripts/paper-scene.sh "$name")
        echo "== the paper's literal numerics:"
        PY=$py bash scripts/validate-run.sh "${name}_paper" "$scene"
        "$py" postprocess/plot_flank.py "runs/${name}_paper"
    done
    if [ -z "${GEARS_ONLY:-}" ]; then
        PY=$py PAPER_ONLY=1 bash scripts/validate-mpr.sh || true
    fi
fi
if [ -z "${PAPER_ONLY:-}" ]; then
    for beta in ${SLOPES-15 60 120}; do
        scene=$(bash scripts/slope-scene.sh paper_gear_z23 "$beta")
        echo "== the gear trends' sensitivity to the slope: β_x = $beta µm"
        PY=$py bash scripts/validate-run.sh "paper_gear_z23_beta$beta" "$scene"
        "$py" postprocess/plot_flank.py "runs/paper_gear_z23_beta$beta"
    done
fi
status=0
[ "${REPORT:-1}" != 0 ] || { echo "validation runs: $(( ($(date +%s) - t0) / 60 )) min on $np ranks; REPORT=0: no report"; exit 0; }
"$py" postprocess/validation_report.py --runs runs --out docs/validation || status=1
echo "validation: $(( ($(date +%s) - t0) / 60 )) min on $np ranks; report docs/validation/README.md"
exit $status
