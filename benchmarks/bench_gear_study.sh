#!/usr/bin/env bash
# The paper's 33-item gear study (scenes/paper_gear_z23.toml with study.patches = 1: 11
# positions × 3 wear coefficients, 3 M cycles in blocks of 1 M) on 1 and 2 ranks of this
# machine: wall time, parallel efficiency, the -log_view profile (stages and events) of each
# run, and a check that both runs wrote the same summary.csv (bitwise; docs/performance.md).
#
#   bash benchmarks/bench_gear_study.sh            # NPS="1 2" CYCLES_M=3 OUT=runs/bench_gear_study
#   NPS=2 bash benchmarks/bench_gear_study.sh      # the 10-minute target alone
#   RPI=2 NPS=2 POSITIONS="3" bash ...             # one position, 2 ranks per item (slabs)
#   BALANCE=static NPS=2 bash ...                  # items round robin (default: dynamic)
#   LIFE="max_wear_fraction = 0.4" NPS=2 bash ...  # lines appended to the scene's [life]
#
# Prints one line per run: ranks, ranks per item, items, wall [s], efficiency against the
# first run, and the share of the blocks stage spent in the contact, stress (FFT) and Dang
# Van events (profile.txt beside each run's results).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
py=$(bash scripts/setup.sh)
source scripts/mpi-env.sh
nps=${NPS:-"1 2"}
rpi=${RPI:-1}
balance=${BALANCE:-dynamic}
cycles=${CYCLES_M:-3.0}
out=${OUT:-runs/bench_gear_study}
mkdir -p "$out"
scene="$out/paper_gear_z23_33.toml"
sed -e 's/^patches = 2 .*/patches = 1/' -e "s/^cycles_M = .*/cycles_M = $cycles/" \
    scenes/paper_gear_z23.toml > "$scene"
grep -q '^patches = 1' "$scene" || { echo "bench_gear_study: could not set patches = 1" >&2; exit 2; }
# [life] is the scene's last table: LIFE's lines (newline-separated settings) go into it
[ -z "${LIFE:-}" ] || printf '%b\n' "$LIFE" >> "$scene"
posargs=()
for p in ${POSITIONS:-}; do posargs+=(--position "$p"); done
first=""
for np in $nps; do
    dir="$out/np$np-rpi$rpi"
    rm -rf "$dir"
    t0=$(date +%s.%N)
    mpirun -n "$np" "$py" -m micropit_hpc run "$scene" --out "$dir" --ranks-per-item "$rpi" \
        --balance "$balance" "${posargs[@]}" -log_view ":$dir.profile.txt" > "$dir.log" 2>&1 \
        || { echo "bench_gear_study: run on $np ranks failed, see $dir.log" >&2; tail "$dir.log" >&2; exit 1; }
    t1=$(date +%s.%N)
    mv "$dir.profile.txt" "$dir/profile.txt"
    "$py" - "$dir" "$np" "$rpi" "$t0" "$t1" "${first:-}" <<'PY'
import csv, re, sys
from pathlib import Path
d, np_, rpi, t0, t1, first = sys.argv[1:7]
wall = float(t1) - float(t0)
items = len({r["item"] for r in csv.DictReader(open(Path(d) / "summary.csv"))})
prof = (Path(d) / "profile.txt").read_text()
def t(name):
    m = re.search(rf"^{name}\s+\d+\s+[\d.]+\s+([\d.e+-]+)", prof, re.M)
    return float(m.group(1)) if m else 0.0
blocks = re.search(r"^\s*\d+:\s+blocks:\s+([\d.e+-]+)", prof, re.M)
blocks = float(blocks.group(1)) if blocks else float("nan")
eff = ""
if first:
    w1, n1 = map(float, first.split(":"))
    eff = f", efficiency {w1 * n1 / (wall * float(np_)):.0%} against {n1:g} rank(s)"
print(f"ranks {np_}, {rpi} per item, {items} items: wall {wall:.0f} s{eff}; blocks stage "
      f"{blocks:.0f} s (rank 0): contact {t('contact') / blocks:.0%}, stresses "
      f"{t('stresses') / blocks:.0%}, Dang Van {(t('dang_van') + t('dang_van_macro')) / blocks:.0%}, "
      f"rest {1 - (t('contact') + t('stresses') + t('dang_van') + t('dang_van_macro')) / blocks:.0%}")
with open(Path(d) / "wall.txt", "w") as f:
    f.write(f"{wall:.3f} {np_}\n")
PY
    read -r w n < "$dir/wall.txt"
    if [ -z "$first" ]; then first="$w:$n"; ref="$dir"; else
        if cmp -s "$ref/summary.csv" "$dir/summary.csv"; then
            echo "summary.csv identical to $ref"
        else
            echo "summary.csv DIFFERS from $ref" >&2
        fi
    fi
done
