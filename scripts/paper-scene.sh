#!/usr/bin/env bash
# Writes runs/scenes/<name>_paper.toml, the scene's literal twin: scenes/<name>.toml with
# `integration = "adaptive"` in its [life] table replaced by `integration = "paper"` (the paper's
# literal numerics: fixed blocks of ΔN, one evaluation per block on its starting surfaces,
# explicit wear ΔN·Δh; docs/life.md, "Two time integrations"), for the validation's
# side-by-side, and prints its path. Refuses a scene without that line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
name=$1
src="$root/scenes/$name.toml"
[ -f "$src" ] || { echo "paper-scene: no scene file $src" >&2; exit 1; }
grep -q '^integration = "adaptive"' "$src" || { echo "paper-scene: $src has no 'integration = \"adaptive\"' line" >&2; exit 1; }
mkdir -p "$root/runs/scenes"
out="runs/scenes/${name}_paper.toml"
{
    echo "# Written by scripts/paper-scene.sh from scenes/$name.toml (edit that, not this): its"
    echo "# literal twin, the paper's numerics (integration = \"paper\"), one key changed."
    sed 's/^integration = "adaptive"/integration = "paper"/' "$src"
} > "$root/$out"
echo "$out"
