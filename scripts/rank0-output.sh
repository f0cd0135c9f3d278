#!/usr/bin/env bash
# Run a command under mpirun so that only rank 0 writes to the terminal; other ranks write to
# LOGDIR/rank<N>.log (printed by the caller when the run fails). Usage: rank0-output.sh LOGDIR CMD...
logdir=$1; shift
rank=${OMPI_COMM_WORLD_RANK:-${PMI_RANK:-${PMIX_RANK:-0}}}
if [[ "$rank" != 0 ]]; then
    exec "$@" >"$logdir/rank$rank.log" 2>&1
fi
exec "$@"
