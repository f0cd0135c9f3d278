#!/usr/bin/env bash
# Writes runs/scenes/<name>_beta<B>.toml, a sensitivity variant of a scene for the validation:
# scenes/<name>.toml with the correlation length along rolling of both surfaces
# (`corr_x_um = ...` in [body1.surface] and [body2.surface]) set to B µm, and nothing else
# changed, so the surfaces keep their R_q and their lay across rolling while their RMS slope
# scales with 1/B (the paper's flanks' slope is not published: docs/validation/findings.md).
# Prints the file's path. Refuses a scene without exactly two `corr_x_um = ` lines, and a B
# that is not a positive number. Usage: bash scripts/slope-scene.sh paper_gear_z23 60
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
[ $# -eq 2 ] || { echo "usage: slope-scene.sh NAME BETA_UM" >&2; exit 2; }
name=$1
beta=$2
src="$root/scenes/$name.toml"
[ -f "$src" ] || { echo "slope-scene: no scene file $src" >&2; exit 1; }
[[ "$beta" =~ ^[0-9]+([.][0-9]+)?$ ]] && [[ ! "$beta" =~ ^0+([.]0+)?$ ]] \
    || { echo "slope-scene: BETA_UM = '$beta' is not a positive number of µm" >&2; exit 1; }
lines=$(grep -c '^corr_x_um = ' "$src" || true)
[ "$lines" -eq 2 ] || { echo "slope-scene: $src has $lines 'corr_x_um = ' lines, not 2 (one per surface)" >&2; exit 1; }
mkdir -p "$root/runs/scenes"
out="runs/scenes/${name}_beta${beta}.toml"
{
    echo "# Written by scripts/slope-scene.sh from scenes/$name.toml (edit that, not this): both"
    echo "# surfaces' correlation length along rolling set to $beta µm, one key changed per surface."
    sed "s/^corr_x_um = .*/corr_x_um = $beta/" "$src"
} > "$root/$out"
echo "$out"
