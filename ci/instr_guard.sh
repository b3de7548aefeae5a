#!/usr/bin/env bash
# Regression guard for the speed of `eval` (issue 29): counts the instructions
# `mapgauge eval` executes on a small dense, cluttered synthetic scene under
# `valgrind --tool=callgrind` (one rayon thread: the count is the same run to
# run whatever the machine's load) and fails when it exceeds the committed
# budget in ci/instr_budget.txt by more than 25 %. No wall-clock is asserted.
#
# The scene: three targets 4-8 m from a walking-pace path in 1 M points, a
# container side 0.1 m behind target 1 and a 0.4 m pallet stack inside its L
# (the clutter issue's wall and stack cases). The tight crop's L finder before
# issue 29 spent 10x the instructions here (each 2 cm row of a plate's band
# rescanned every point near the plate).
#
# Usage: ci/instr_guard.sh [BIN]      (default target/release/mapgauge)
#        BLESS=1 ci/instr_guard.sh    writes the measured count as the budget
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-target/release/mapgauge}
BUDGET_FILE=ci/instr_budget.txt
if ! command -v valgrind >/dev/null; then
    echo "installing valgrind" >&2
    apt-get install -y valgrind >/dev/null 2>&1 || { echo "error: valgrind missing and not installable" >&2; exit 1; }
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat >"$work/scene.toml" <<'TOML'
targets = 3
spread_m = 20.0
target_distance_m = [4.0, 8.0]
[lidar]
max_range_m = 40.0
[obstacles]
wall_behind_m = 0.1
inside_object_m = 0.4
TOML
"$BIN" synth --config "$work/scene.toml" --points 1000000 --seed 3 --out "$work/scene" >/dev/null 2>&1
RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$work/cg.out" \
    "$BIN" eval --no-report --map "$work/scene/map.ply" --survey "$work/scene/survey.csv" \
    --out "$work/eval" >/dev/null 2>"$work/valgrind.err" || {
    tail -n 20 "$work/valgrind.err" >&2
    echo "error: eval failed under callgrind" >&2
    exit 1
}
count=$(sed -n 's/^==[0-9]*== Collected : \([0-9]*\)$/\1/p' "$work/valgrind.err")
[[ -n "$count" ]] || { echo "error: no instruction count in callgrind's output" >&2; exit 1; }
found=$(grep -c ',ok,' "$work/eval/targets.csv" || true)
if [[ "$found" -ne 3 ]]; then
    echo "error: the guard scene found $found of 3 targets: the count measures the wrong work" >&2
    exit 1
fi
if [[ -n "${BLESS:-}" ]]; then
    echo "$count" >"$BUDGET_FILE"
    echo "instruction budget blessed: $count"
    exit 0
fi
budget=$(tr -dc '0-9' <"$BUDGET_FILE")
ratio=$(awk -v c="$count" -v b="$budget" 'BEGIN{printf "%.3f", c/b}')
echo "eval instruction count: $count, budget $budget (ratio $ratio; fails above 1.25)"
if awk -v r="$ratio" 'BEGIN{exit !(r > 1.25)}'; then
    echo "error: eval executes $ratio x its instruction budget: a speed regression (profile with callgrind_annotate; BLESS=1 only for a change that needs the work)" >&2
    exit 1
fi
if awk -v r="$ratio" 'BEGIN{exit !(r < 0.7)}'; then
    echo "note: eval runs well under its budget; lower it with BLESS=1 $0 so the guard keeps its edge" >&2
fi
