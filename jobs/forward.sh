# Sourced by the job scripts (jobs/local.sh, jobs/slurm_array.sh, jobs/pbs.sh); needs their log()
# and EXIT_CHECKPOINTED.
#
# run_forwarding NOTE OUT CMD...: run CMD (the launcher: mpirun or srun, running `micropit run
# --out OUT`) in the background and wait for it; a SIGUSR1 or SIGTERM received by this shell is
# delivered to the ranks as SIGUSR1; sets rc to the run's exit status (see "Which exit code"
# below). NOTE is added to the log line of a SIGUSR1 (e.g. "time limit near").
#
# Why SIGUSR1 for both: the ranks stop at the next block boundary with a checkpoint and exit 85
# on either signal, but the launchers treat SIGTERM as "kill the job": Open MPI's mpirun sends
# SIGTERM, then SIGKILL, to the ranks (no checkpoint), whereas it relays SIGUSR1 (and srun both)
# to every rank on every node untouched. So a stop request sent to this shell travels as
# SIGUSR1 through the launcher's relay path, never through its kill path.
#
# A time limit or `scancel` signals every process of the job at once (the whole process group,
# or all of the job's processes): the ranks then get SIGTERM themselves and stop at the next
# block boundary, while mpirun, signalled too, would kill them one second later
# (odls_base_sigkill_timeout) and then exit 1. KILL_GRACE_S (default 30, Slurm's KillWait)
# sets that timeout instead: mpirun leaves the ranks that long before it signals them, and as
# long again before SIGKILL, so a block that ends within it is checkpointed.
#
# Which exit code: the launcher's, except where it says less than the run did:
# * the run's own code, written by rank 0 into OUT/.micropit.exit as it ends (0 or 85), when the
#   launcher exits otherwise (mpirun exits 1 after its own SIGTERM, whatever the ranks did);
# * 85 when a stop signal reached this shell, killed the launcher, or reached the ranks (rank 0
#   writes "signal N" into OUT/.micropit.exit at once), and the ranks were killed before the
#   next block boundary: the last complete checkpoint stands, the block in progress is lost,
#   and the requeued job continues from that checkpoint.
#
# Why this shape: bash runs a trap only between commands or during `wait`, so the launcher runs
# in the background. The signal goes to the launcher only: mpirun and srun both relay SIGUSR1 to
# every rank on every node; signalling the launcher's whole process group would also hit the
# local ranks directly (twice), and any process in that group without a handler (a helper, a rank
# still importing Python) would die of SIGUSR1, whose default action is to terminate. A trapped
# signal interrupts `wait` with a status > 128 while the run goes on: we then wait again (bash
# remembers the status of a child that ended meanwhile).
run_forwarding() {
    local note=$1 out=$2
    shift 2
    rm -f "$out/.micropit.exit"
    export OMPI_MCA_odls_base_sigkill_timeout=${OMPI_MCA_odls_base_sigkill_timeout:-${KILL_GRACE_S:-30}}
    "$@" &
    _forward_pid=$!
    _forward_got=0
    _forward_stop=0
    # shellcheck disable=SC2064  # the note is fixed now, on purpose
    trap "_forward USR1 '$note'" USR1
    trap '_forward TERM' TERM
    rc=0
    while :; do
        wait "$_forward_pid" && rc=0 || rc=$?
        if ((rc > 128 && _forward_got)); then _forward_got=0; continue; fi
        break
    done
    trap - USR1 TERM
    _settle_exit "$out"
}

_forward() {
    _forward_got=1
    _forward_stop=1
    log "SIG$1${2:+ ($2)}: asking the ranks to checkpoint and stop (SIGUSR1 through the launcher)"
    kill -USR1 "$_forward_pid" 2>/dev/null || true
}

_settle_exit() {
    local out=$1 own="" own_text=""
    case $rc in 0 | 2 | "$EXIT_CHECKPOINTED") return ;; esac
    [[ -r "$out/.micropit.exit" ]] && own_text=$(head -c 100 "$out/.micropit.exit")
    [[ "$own_text" =~ ^[0-9]+$ ]] && own=$own_text
    if [[ "$own" == 0 || "$own" == "$EXIT_CHECKPOINTED" ]]; then
        log "the launcher exited $rc, the run itself $own ($out/.micropit.exit: the signal reached" \
            "the launcher too, as a time limit or scancel sends it); exit code $own"
        rc=$own
    elif { ((_forward_stop || rc > 128)) || [[ "$own_text" == signal* ]]; } \
            && [[ -s "$out/checkpoints/LATEST" ]]; then
        log "stopped by a signal before the next block boundary (launcher exit $rc): the last" \
            "checkpoint, $out/checkpoints/$(cat "$out/checkpoints/LATEST"), stands (the block" \
            "in progress is lost); exit code $EXIT_CHECKPOINTED"
        rc=$EXIT_CHECKPOINTED
    fi
}
