#!/usr/bin/env bash
# =================================================================================================
# micropit_hpc on Slurm: a job array of life simulations that checkpoint and requeue themselves.
# (docs/jobs.md explains the whole mechanism; docs/hpc.md §3 "Long jobs" the design.)
#
# Submit from the repository root (the job finds the code through $SLURM_SUBMIT_DIR):
#
#   One array task per scene (task i runs the i-th scene given; here 3 scenes):
#     sbatch --array=1-3 jobs/slurm_array.sh scenes/gear_z23.toml scenes/a.toml scenes/b.toml
#   or with the scenes listed in a file, one per line:
#     SCENE_LIST=my_scenes.txt sbatch --array=1-$(wc -l < my_scenes.txt) jobs/slurm_array.sh
#   One array task per position of one scene (task i runs position i, 1-based):
#     MODE=positions sbatch --array=1-12 jobs/slurm_array.sh scenes/gear_z23.toml
#
# What happens in each array task:
#   1. `micropit check-env --expect-ranks N` on all N ranks: a wrong MPI library, a serial h5py
#      or a missing petsc4py fails here, in seconds, not hours into the run (docs/hpc.md §1 trap 5).
#   2. `micropit run SCENE --out DIR --restart --stop-file DIR/STOP`: --restart continues from
#      the newest complete checkpoint in DIR (a fresh start when there is none).
#   3. The run gets a wall-time budget by default: the job's end time (squeue, exported as
#      SLURM_JOB_END_TIME) less 120 s; at each block boundary the ranks stop when the next block
#      (1.2 × the longest block so far plus a checkpoint, measured) would overrun it, write a
#      checkpoint and exit with code 85. As a backstop, 600 s before the time limit Slurm sends
#      SIGUSR1 to this batch shell (--signal=B:USR1@600); the trap below (jobs/forward.sh)
#      delivers it, and any SIGTERM, to the ranks as SIGUSR1 through the launcher's relay: at
#      the next block boundary they checkpoint and exit 85. A SIGTERM to every process of the
#      job (the limit, scancel) reaches the ranks directly and ends the same way; the exit code
#      is then the run's own (OUT/.micropit.exit), not mpirun's 1 (jobs/forward.sh).
#   4. On exit code 85 this script requeues the task (`scontrol requeue`): the same task starts
#      again later, with the same arguments, and step 2 resumes from the checkpoint.
#      Any other exit code ends the task (0: finished; anything else: an error, see the log).
#
# Stopping a task by hand: `touch DIR/STOP` (checkpoint at the next block boundary, exit 85,
# NOT requeued while the STOP file exists); remove DIR/STOP before resubmitting. Or
# `scancel --signal=USR1 --batch JOBID_TASK` to checkpoint and requeue now.
#
# Knobs (environment variables, given to sbatch with --export=ALL,VAR=value or exported before):
#   MODE=scenes|positions   what the array index selects (default scenes)
#   TASK=K                  use K instead of the array index (a job that is not an array)
#   SCENE_LIST=FILE         scenes, one per line (instead of script arguments)
#   OUT_ROOT=DIR            results go to OUT_ROOT/<scene name>[/position_<k>] (default runs)
#   LAUNCHER=mpirun|srun    how ranks are started (default mpirun: the MPI library of mpi4py
#                           must be the launcher's; srun needs Slurm's PMI support in that MPI)
#   POSITION_OPT=--position the option of `micropit run` that selects one position (MODE=positions)
#   MAX_WALL=SECONDS        the run's wall-time budget (default: the job's end less 120 s)
#   MAX_REQUEUES=N          stop requeueing after N requeues (default 50; runaway protection)
#   MICROPIT_PYTHON=PATH    the interpreter (default .venv/bin/python from scripts/setup.sh)
#   MICROPIT_ROOT=DIR       the repository (default: the directory sbatch was run in)
#   RUN_ARGS="..."          extra arguments for `micropit run`
#   KILL_GRACE_S=S          seconds mpirun leaves the ranks to reach a block boundary after it
#                           is signalled itself, before it signals them (default 30)
# =================================================================================================
#SBATCH --job-name=micropit
#SBATCH --ntasks=4
#SBATCH --cpus-per-task=1
#SBATCH --time=24:00:00
#SBATCH --signal=B:USR1@600
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --output=micropit_%A_%a.out
set -euo pipefail
# On a cluster, load the site's MPI, parallel HDF5 and PETSc modules here, the ones the
# environment of MICROPIT_PYTHON was built with (docs/install.md), e.g.
#   module load openmpi hdf5/parallel petsc

EXIT_CHECKPOINTED=85  # micropit_hpc.parallel.control.EXIT_CHECKPOINTED
log() { printf '[%s job %s] %s\n' "$(date -u +%FT%TZ)" "${SLURM_JOB_ID:-?}" "$*"; }
die() { log "error: $*"; exit 2; }

# Slurm runs a copy of this script from its spool directory, so $0 says nothing about where the
# code is: use the submission directory (or MICROPIT_ROOT).
root=${MICROPIT_ROOT:-${SLURM_SUBMIT_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}}
[[ -d "$root/micropit_hpc" ]] || die "no micropit_hpc in $root: submit from the repository root or set MICROPIT_ROOT"
cd "$root"
# Workstation/container settings of Open MPI and H5PY_ALWAYS_USE_MPI=1 (docs/hpc.md §1 traps 2, 6).
source scripts/mpi-env.sh
# The venv made by scripts/setup.sh (run it once on a login node before submitting).
py=${MICROPIT_PYTHON:-$root/.venv/bin/python}
[[ -x "$py" ]] || die "no interpreter $py: run 'bash scripts/setup.sh' first or set MICROPIT_PYTHON"

# ---- which scene / position this array task runs ------------------------------------------------
task=${TASK:-${SLURM_ARRAY_TASK_ID:-1}}
if [[ -n "${SCENE_LIST:-}" ]]; then
    mapfile -t scenes < <(grep -v '^[[:space:]]*\(#\|$\)' "$SCENE_LIST")
else
    scenes=("$@")
fi
((${#scenes[@]})) || die "no scene: give scene files as arguments or SCENE_LIST=FILE"
mode=${MODE:-scenes}
run_extra=()
case "$mode" in
    scenes)
        ((task >= 1 && task <= ${#scenes[@]})) || die "array index $task, but ${#scenes[@]} scenes"
        scene=${scenes[task - 1]}
        out=${OUT_ROOT:-runs}/$(basename "$scene" .toml)
        ;;
    positions)
        scene=${scenes[0]}
        out=${OUT_ROOT:-runs}/$(basename "$scene" .toml)/position_$task
        run_extra=("${POSITION_OPT:---position}" "$task")
        ;;
    *) die "MODE must be scenes or positions, not $mode" ;;
esac
[[ -f "$scene" ]] || die "no scene file $scene"
mkdir -p "$out"
stop_file=$out/STOP

# ---- launcher --------------------------------------------------------------------------------------
np=${SLURM_NTASKS:-${NP:-1}}
case "${LAUNCHER:-mpirun}" in
    mpirun) launch=(mpirun -n "$np") ;;
    srun)   launch=(srun --ntasks="$np" --kill-on-bad-exit=1) ;;
    *) die "LAUNCHER must be mpirun or srun" ;;
esac
log "task $task: scene $scene, $np ranks, output $out (requeue count ${SLURM_RESTART_COUNT:-0})"

# ---- 1. environment check ---------------------------------------------------------------------------
"${launch[@]}" "$py" -m micropit_hpc check-env --expect-ranks "$np" \
    || die "check-env failed (see above); not running, not requeueing"

# ---- 2. the run: --restart continues from the newest checkpoint (a fresh start when none) ----------
args=(run "$scene" --out "$out" --restart --stop-file "$stop_file" "${run_extra[@]}")
if [[ -n "${MAX_WALL:-}" ]]; then
    args+=(--max-wall "$MAX_WALL")
elif [[ -z "${SLURM_JOB_END_TIME:-}" && -n "${SLURM_JOB_ID:-}" ]] && command -v squeue >/dev/null; then
    # the default budget of `micropit run` reads the job's end (epoch seconds) from here
    end=$(squeue -h -j "$SLURM_JOB_ID" -o %e 2>/dev/null | head -n 1)
    if end_s=$(date -d "$end" +%s 2>/dev/null); then
        export SLURM_JOB_END_TIME=$end_s
        log "job ends at $end: the run stops at the block boundary before it (less 120 s)"
    else
        log "warning: cannot read the job's end time ('$end'); no wall-time budget, only the signal"
    fi
fi
# shellcheck disable=SC2206  # RUN_ARGS is split on purpose
[[ -z "${RUN_ARGS:-}" ]] || args+=(${RUN_ARGS})

# ---- 3. forward Slurm's early warning (SIGUSR1) and SIGTERM (scancel, the limit) to the launcher --
source jobs/forward.sh
run_forwarding "time limit near" "$out" "${launch[@]}" "$py" -m micropit_hpc "${args[@]}"

# ---- 4. requeue on "checkpointed, not finished" -----------------------------------------------------
case $rc in
    0) log "finished: results in $out" ;;
    "$EXIT_CHECKPOINTED")
        if [[ -e "$stop_file" ]]; then
            log "stopped by $stop_file after a checkpoint; not requeueing (remove it, then resubmit)"
        elif ((${SLURM_RESTART_COUNT:-0} >= ${MAX_REQUEUES:-50})); then
            log "checkpointed, but requeued ${SLURM_RESTART_COUNT} times already (MAX_REQUEUES); not requeueing"
        elif [[ -z "${SLURM_JOB_ID:-}" ]]; then
            log "checkpointed; not under Slurm, so not requeueing"
        else
            log "checkpointed before the time limit: requeueing job $SLURM_JOB_ID"
            scontrol requeue "$SLURM_JOB_ID"
        fi
        ;;
    *) log "run failed with exit code $rc; not requeueing" ;;
esac
exit "$rc"
