#!/usr/bin/env bash
# Writes runs/scenes/<name>_adaptive.toml: scenes/<name>.toml with `integration = "paper"` in its
# [life] table replaced by `integration = "adaptive"` (MODEL's second time integration, for the
# validation's side-by-side), and prints its path. Refuses a scene without that line.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
name=$1
src="$root/scenes/$name.toml"
grep -q '^integration = "paper"' "$src" || { echo "adaptive-scene: $src has no 'integration = \"paper\"' line" >&2; exit 1; }
mkdir -p "$root/runs/scenes"
out="runs/scenes/${name}_adaptive.toml"
sed 's/^integration = "paper"/integration = "adaptive"/' "$src" > "$root/$out"
echo "$out"
