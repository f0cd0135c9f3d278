#!/usr/bin/env bash
# One run of the validation: `bash scripts/validate-run.sh NAME SCENE` runs SCENE into runs/NAME/
# on NP ranks (default 2) with the Python that scripts/setup.sh prints (PY, when set, skips it).
#
# Afresh by default (--overwrite). With RESUME=1 the run goes on from its last checkpoint
# (`micropit run --restart`; a finished run, whose manifest.json says done, is left as it is), so
# a validation of many hours can be spread over several sittings: kill it at any time and call the
# same command with RESUME=1. A run is resumed only by the code that began it: the git tree of
# micropit_hpc/ is stamped in runs/.validate/NAME.tree when a run starts afresh, and RESUME=1
# refuses a run folder whose stamp differs from this checkout's tree, has no stamp, or was begun
# (or would go on) with uncommitted changes in micropit_hpc/; it then names the folder and says
# how to start it afresh. The scene itself is checked by --restart (a checkpoint of another
# scene is refused).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
[ $# -eq 2 ] || { echo "usage: validate-run.sh NAME SCENE" >&2; exit 2; }
name=$1
scene=$2
py=${PY:-$(bash scripts/setup.sh)}
source scripts/mpi-env.sh
np=${NP:-2}
stamp_dir=runs/.validate
stamp="$stamp_dir/$name.tree"

# The code's identity: the committed tree of micropit_hpc/, or "uncommitted" when the working
# copy differs from it (such a run can be started, never resumed).
code_tree() {
    local tree
    tree=$(git -C "$root" rev-parse HEAD:micropit_hpc 2>/dev/null) || { echo "no-git"; return; }
    if [ -n "$(git -C "$root" status --porcelain -- micropit_hpc 2>/dev/null)" ]; then
        echo "uncommitted"
    else
        echo "$tree"
    fi
}

tree=$(code_tree)
mode=--overwrite
if [ -n "${RESUME:-}" ] && [ -d "runs/$name" ]; then
    again="start it afresh with: bash scripts/validate-run.sh $name $scene (without RESUME)"
    if [ ! -f "$stamp" ]; then
        echo "validate-run: RESUME=1: runs/$name/ has no stamp $stamp (not begun by validate-run.sh); $again" >&2
        exit 3
    fi
    was=$(cat "$stamp")
    case "$tree:$was" in
        no-git:*|uncommitted:*|*:no-git|*:uncommitted)
            echo "validate-run: RESUME=1: runs/$name/ was begun by micropit_hpc tree '$was', this checkout has '$tree'; only committed code of one git tree resumes; $again" >&2
            exit 3 ;;
    esac
    if [ "$was" != "$tree" ]; then
        echo "validate-run: RESUME=1: runs/$name/ was begun by micropit_hpc tree $was, this checkout has $tree (the code changed); $again" >&2
        exit 3
    fi
    mode=--restart
    # a finished run is left as it is: writing its results again would record that leg's wall
    # time and commit instead of those of the run
    if grep -q '"status": "done"' "runs/$name/manifest.json" 2>/dev/null; then
        echo "== runs/$name/ is finished (its manifest.json says done): left as it is"
        exit 0
    fi
fi
if [ "$mode" = --overwrite ]; then
    mkdir -p "$stamp_dir"
    echo "$tree" > "$stamp"
fi
echo "== micropit run $scene on $np ranks into runs/$name ($mode)"
mpirun -n "$np" "$py" -m micropit_hpc run "$scene" --out "runs/$name" "$mode"
