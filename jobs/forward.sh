# Sourced by the batch scripts (jobs/slurm_array.sh, jobs/pbs.sh); needs their log().
#
# run_forwarding NOTE CMD...: run CMD (the launcher: mpirun or srun) in the background and wait
# for it; a SIGUSR1 or SIGTERM received by this batch shell is delivered to the ranks as SIGUSR1;
# sets rc to CMD's exit status. NOTE is added to the log line of a SIGUSR1 (e.g. "time limit
# near").
#
# Why SIGUSR1 for both: the ranks stop at the next block boundary with a checkpoint and exit 85
# on either signal, but the launchers treat SIGTERM as "kill the job": Open MPI's mpirun sends
# SIGTERM then SIGKILL to the ranks at once (no checkpoint, exit 1, not requeued), whereas it
# relays SIGUSR1 (and srun both) to every rank on every node untouched. So the stop request
# travels as SIGUSR1 through the launcher's relay path, never through its kill path.
#
# Why this shape: bash runs a trap only between commands or during `wait`, so the launcher runs
# in the background. The signal goes to the launcher only: mpirun and srun both relay SIGUSR1 to
# every rank on every node; signalling the launcher's whole process group would also hit the
# local ranks directly (twice), and any process in that group without a handler (a helper, a rank
# still importing Python) would die of SIGUSR1, whose default action is to terminate. A trapped
# signal interrupts `wait` with a status > 128 while the run goes on: we then wait again (bash
# remembers the status of a child that ended meanwhile).
run_forwarding() {
    local note=$1
    shift
    "$@" &
    _forward_pid=$!
    _forward_got=0
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
}

_forward() {
    _forward_got=1
    log "SIG$1${2:+ ($2)}: asking the ranks to checkpoint and stop (SIGUSR1 through the launcher)"
    kill -USR1 "$_forward_pid" 2>/dev/null || true
}
