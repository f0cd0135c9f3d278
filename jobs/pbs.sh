#!/usr/bin/env bash
# =================================================================================================
# micropit_hpc on PBS (PBS Pro / OpenPBS; Torque works the same way): a life simulation that
# checkpoints before the wall-time limit and resubmits itself until it is finished.
# (docs/jobs.md explains the whole mechanism; docs/hpc.md §3 "Long jobs" the design.)
#
# Submit from the repository root; PBS passes no script arguments, so the scene is a variable:
#     qsub -v SCENE=scenes/gear_z23.toml jobs/pbs.sh
#     qsub -v SCENE=scenes/gear_z23.toml,OUT_DIR=runs/z23_long,MARGIN_S=900 jobs/pbs.sh
#
# What happens:
#   1. `micropit check-env --expect-ranks N` on all N ranks (a wrong MPI library, a serial h5py or
#      a missing petsc4py fails here, in seconds; docs/hpc.md §1 trap 5).
#   2. PBS sends no early warning before the wall-time limit (only SIGTERM, then SIGKILL a few
#      seconds later). So the run gets a budget instead: --max-wall = walltime - MARGIN_S - the
#      time this script has used so far. At each block boundary the ranks stop when the next
#      block would overrun the budget, write a checkpoint and exit with code 85.
#      The next block's duration is measured (1.2 × the longest block so far plus one
#      checkpoint), so MARGIN_S (default 300 s) only has to cover writing the results and MPI
#      shutdown. A SIGTERM (qdel, the limit) or `qsig -s USR1` reaches the ranks as SIGUSR1
#      (jobs/forward.sh): checkpoint at the next block boundary and exit 85.
#   3. `micropit run SCENE --out DIR --restart --max-wall S --stop-file DIR/STOP`: --restart
#      continues from the newest complete checkpoint in DIR (a fresh start when there is none).
#   4. On exit code 85 the script submits itself again (`qsub`), with the same variables and a
#      dependency on this job (`-W depend=afterany:THIS_JOB`), so the next part cannot start
#      while this one is still writing. Any other exit code ends the chain.
#
# Stopping by hand: `touch DIR/STOP` (checkpoint at the next block boundary, exit 85, no
# resubmission while the STOP file exists; remove it before submitting again). `qsig -s USR1
# JOBID` also checkpoints at the next boundary and resubmits (the signal reaches the ranks).
#
# Resources are the #PBS lines below (a resubmission reuses them; options given to the first
# qsub on its command line are NOT carried over unless put in QSUB_ARGS, see below).
#
# Variables (qsub -v NAME=value,...):
#   SCENE=FILE            the scene (required)
#   OUT_DIR=DIR           output and checkpoints (default runs/<scene name>)
#   NP=N                  ranks (default: the lines of $PBS_NODEFILE, i.e. mpiprocs in total)
#   WALLTIME=HH:MM:SS     the job's wall-time limit (default: read from qstat -f)
#   MARGIN_S=SECONDS      kept free at the end of the wall time (default 300)
#   MAX_RESUBMITS=N       the longest chain of resubmissions (default 50; runaway protection)
#   QSUB_ARGS="..."       extra qsub options for the resubmission (e.g. "-q long -A proj")
#   MICROPIT_PYTHON=PATH  the interpreter (default .venv/bin/python from scripts/setup.sh)
#   MICROPIT_ROOT=DIR     the repository (default: the directory qsub was run in)
#   RUN_ARGS="..."        extra arguments for `micropit run`
# =================================================================================================
#PBS -N micropit
#PBS -l select=1:ncpus=4:mpiprocs=4
#PBS -l walltime=24:00:00
#PBS -j oe
#PBS -r y
set -euo pipefail
# On a cluster, load the site's MPI, parallel HDF5 and PETSc modules here, the ones the
# environment of MICROPIT_PYTHON was built with (docs/install.md), e.g.
#   module load openmpi hdf5/parallel petsc

EXIT_CHECKPOINTED=85  # micropit_hpc.parallel.control.EXIT_CHECKPOINTED
log() { printf '[%s job %s] %s\n' "$(date -u +%FT%TZ)" "${PBS_JOBID:-?}" "$*"; }
die() { log "error: $*"; exit 2; }

# PBS runs a copy of this script, so $0 says nothing about where the code is: use the directory
# qsub was run in (or MICROPIT_ROOT).
root=${MICROPIT_ROOT:-${PBS_O_WORKDIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}}
[[ -d "$root/micropit_hpc" ]] || die "no micropit_hpc in $root: submit from the repository root or set MICROPIT_ROOT"
cd "$root"
# Workstation/container settings of Open MPI and H5PY_ALWAYS_USE_MPI=1 (docs/hpc.md §1 traps 2, 6).
source scripts/mpi-env.sh
# The venv made by scripts/setup.sh (run it once on a login node before submitting).
py=${MICROPIT_PYTHON:-$root/.venv/bin/python}
[[ -x "$py" ]] || die "no interpreter $py: run 'bash scripts/setup.sh' first or set MICROPIT_PYTHON"

scene=${SCENE:-}
[[ -n "$scene" ]] || die "no scene: qsub -v SCENE=scenes/NAME.toml jobs/pbs.sh"
[[ -f "$scene" ]] || die "no scene file $scene"
out=${OUT_DIR:-runs/$(basename "$scene" .toml)}
mkdir -p "$out"
stop_file=$out/STOP
part=${RESUBMIT:-0}  # how many times this chain has been resubmitted

if [[ -n "${NP:-}" ]]; then
    np=$NP
elif [[ -n "${PBS_NODEFILE:-}" && -r "$PBS_NODEFILE" ]]; then
    np=$(wc -l < "$PBS_NODEFILE")
else
    np=1
fi

# ---- the wall-time budget ---------------------------------------------------------------------------
to_seconds() {  # [[HH:]MM:]SS -> seconds
    local IFS=: parts s=0 p
    read -r -a parts <<< "$1"
    for p in "${parts[@]}"; do s=$((s * 60 + 10#$p)); done
    echo "$s"
}
walltime=${WALLTIME:-}
if [[ -z "$walltime" && -n "${PBS_JOBID:-}" ]] && command -v qstat >/dev/null; then
    walltime=$(qstat -f "$PBS_JOBID" 2>/dev/null | sed -n 's/^ *Resource_List.walltime = //p' | head -n 1)
fi
[[ -n "$walltime" ]] || die "unknown wall-time limit: set WALLTIME=HH:MM:SS"
margin=${MARGIN_S:-300}
log "part $part: scene $scene, $np ranks, output $out, walltime $walltime, margin $margin s"

# ---- 1. environment check ---------------------------------------------------------------------------
mpirun -n "$np" "$py" -m micropit_hpc check-env --expect-ranks "$np" \
    || die "check-env failed (see above); not running, not resubmitting"

# ---- 2./3. the run with what is left of the budget --------------------------------------------------
# $SECONDS: the time this script has run so far (queue-to-start time does not count).
max_wall=$(($(to_seconds "$walltime") - margin - SECONDS))
((max_wall > 0)) || die "walltime $walltime leaves no time after the margin of $margin s"
args=(run "$scene" --out "$out" --restart --max-wall "$max_wall" --stop-file "$stop_file")
# shellcheck disable=SC2206  # RUN_ARGS is split on purpose
[[ -z "${RUN_ARGS:-}" ]] || args+=(${RUN_ARGS})
log "budget for the run: $max_wall s"
# A signal (qsig -s USR1, or SIGTERM at the limit) is forwarded to the launcher, which relays it
# to every rank (jobs/forward.sh).
source jobs/forward.sh
run_forwarding "" "$out" mpirun -n "$np" "$py" -m micropit_hpc "${args[@]}"

# ---- 4. resubmit on "checkpointed, not finished" ----------------------------------------------------
case $rc in
    0) log "finished: results in $out" ;;
    "$EXIT_CHECKPOINTED")
        if [[ -e "$stop_file" ]]; then
            log "stopped by $stop_file after a checkpoint; not resubmitting (remove it, then qsub again)"
        elif ((part >= ${MAX_RESUBMITS:-50})); then
            log "checkpointed, but this chain has $part parts already (MAX_RESUBMITS); not resubmitting"
        elif [[ -z "${PBS_JOBID:-}" ]]; then
            log "checkpointed; not under PBS, so not resubmitting"
        else
            # MICROPIT_PREVIOUS_JOB: a lock this job left in $out (killed) is stale for the next
            vars="SCENE=$scene,OUT_DIR=$out,RESUBMIT=$((part + 1)),MICROPIT_ROOT=$root"
            vars+=",MICROPIT_PREVIOUS_JOB=$PBS_JOBID"
            for v in NP WALLTIME MARGIN_S MAX_RESUBMITS MICROPIT_PYTHON RUN_ARGS QSUB_ARGS; do
                [[ -z "${!v:-}" ]] || vars+=",$v=${!v}"
            done
            # shellcheck disable=SC2206  # QSUB_ARGS is split on purpose
            extra=(${QSUB_ARGS:-})
            next=$(cd "$root" && qsub "${extra[@]}" -W "depend=afterany:$PBS_JOBID" -v "$vars" \
                   jobs/pbs.sh)
            log "checkpointed before the wall-time limit: resubmitted as $next (part $((part + 1)))"
        fi
        ;;
    *) log "run failed with exit code $rc; not resubmitting" ;;
esac
exit "$rc"
