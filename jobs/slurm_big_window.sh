#!/usr/bin/env bash
# =================================================================================================
# micropit_hpc on Slurm: ONE work item whose window is split over every rank of a multi-node job
# (a measured-map-sized window, e.g. 2048 x 2048: scenes/gear_z23_2048.toml). docs/jobs.md
# "One big window on several nodes" explains it; docs/scaling.md gives the memory and the
# communication per step against the number of ranks.
#
# Submit from the repository root:
#   sbatch jobs/slurm_big_window.sh                                   # position 3 of the 2048² scene
#   POSITION=1 sbatch --nodes=8 jobs/slurm_big_window.sh my_scene.toml
#
# Every rank of the job holds a slab of the window's x rows (--ranks-per-item = all ranks):
# the contact (above 1024^2 cells; up to that each rank solves whole windows, its share of a
# load cycle's time steps: MICROPIT_CONTACT_PARALLEL=auto|steps|slabs, docs/hpc.md section 2),
# the stresses, Dang Van and the damage are computed on the slabs; the checkpoints
# are written collectively (parallel HDF5). Everything else — the environment check, the
# wall-time budget, the signal forwarding, checkpoint-and-requeue with exit 85 — is
# jobs/slurm_array.sh's, which this script runs in positions mode for the one position.
#
# Choose the ranks so that each holds at least one x row and one k_y column (ranks ≤ n/2 + 1 for
# an n x n window) and the estimate printed at the start (memory per rank) fits the nodes'
# memory: `micropit run SCENE --out /tmp/x --position K --ranks-per-item R` prints it and stops
# at once if it does not fit.
#
# Knobs (besides those of jobs/slurm_array.sh): POSITION=K (default 3), the scene as argument
# (default scenes/gear_z23_2048.toml).
# =================================================================================================
#SBATCH --job-name=micropit-big
#SBATCH --nodes=4
#SBATCH --ntasks-per-node=16
#SBATCH --cpus-per-task=1
#SBATCH --mem=0
#SBATCH --time=24:00:00
#SBATCH --signal=B:USR1@600
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --output=micropit_big_%j.out
set -euo pipefail
root=${MICROPIT_ROOT:-${SLURM_SUBMIT_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}}
np=${SLURM_NTASKS:-${NP:-1}}
export MODE=positions TASK=${POSITION:-3}
export RUN_ARGS="--ranks-per-item $np${RUN_ARGS:+ $RUN_ARGS}"
exec bash "$root/jobs/slurm_array.sh" "${1:-scenes/gear_z23_2048.toml}"
