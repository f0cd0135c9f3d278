#!/usr/bin/env bash
# The MPR triple-disc validation of the paper (MODEL.md §7 trends 1 and 7), on NP ranks
# (default 2): runs scenes/paper_mpr.toml (|S| = 0.05, 0.15, 0.30 to 10 M cycles) and
# scenes/paper_mpr_table9.toml (Λ scaling with and without wear), writes the side-by-side
# tables next to the results in runs/paper_mpr/ and runs/paper_mpr_table9/, and prints the
# trend verdicts. Takes about 10 minutes on 2 cores. Exit status 1 if a trend fails.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=$(bash scripts/setup.sh)
source scripts/mpi-env.sh
np=${NP:-2}
status=0
for name in paper_mpr paper_mpr_table9; do
    echo "== micropit run scenes/$name.toml on $np ranks"
    mpirun -n "$np" "$py" -m micropit_hpc run "scenes/$name.toml" --out "runs/$name"
done
echo "== A_p against |S| (trend 1)"
"$py" postprocess/paper_mpr.py mpr runs/paper_mpr || status=1
echo "== A_p against Λ (trend 7)"
"$py" postprocess/paper_mpr.py table9 runs/paper_mpr_table9 || status=1
"$py" postprocess/plot_life.py runs/paper_mpr --out runs/paper_mpr/life.png
"$py" postprocess/plot_life.py runs/paper_mpr_table9 --out runs/paper_mpr_table9/life.png
exit $status
