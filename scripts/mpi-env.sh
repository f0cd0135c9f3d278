# Sourced by the scripts: settings Open MPI needs on a workstation or a container (docs/install.md).
# As root, Open MPI refuses to start without these two:
if [[ $(id -u) -eq 0 ]]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
# Allow more ranks than cores (tests on a 2-core machine ask for 2 ranks while other work runs).
export OMPI_MCA_rmaps_base_oversubscribe=${OMPI_MCA_rmaps_base_oversubscribe:-1}
# Debian's h5py picks its MPI build only when it sees a launcher; ask for it always.
export H5PY_ALWAYS_USE_MPI=${H5PY_ALWAYS_USE_MPI:-1}
