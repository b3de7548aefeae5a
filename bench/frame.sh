#!/usr/bin/env bash
# Issue 15's speed figures: `eval` finding the frame itself (ground pass,
# map-wide detection, matching) against `eval` given the transform, on the
# same map, median of RUNS rounds, with peak memory. Not part of CI.
#
#   bench/frame.sh                 # 20 M points, float32 PCD
#   bench/frame.sh 200000000       # the memory bound at 200 M (f64 PCD, ~5 GB of disk)
#   RUNS=5 DIR=/data bench/frame.sh 20000000
#
# The scene: 8 targets and 10 decoys, yaw 237°, 10 km away, tilted 8°, a
# UTM-size survey. The "given" run gets --hints with every target's true map
# position (what a run given the transform does: one crop pass after the
# ground pass); the "detect" run gets nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
N=${1:-20000000}
RUNS=${RUNS:-3}
DIR=${DIR:-/tmp/mapgauge-bench-frame}
FORMAT=${FORMAT:-pcd-f32}
[ "$N" -gt 50000000 ] && FORMAT=${FORMAT_BIG:-pcd}
cargo build --release --quiet
BIN=$PWD/target/release/mapgauge
S=$DIR/n$N
if [ ! -s "$S/survey.csv" ]; then
  rm -rf "$S"
  # pcd-f32 refuses coordinates beyond 32 km; 10 km fits.
  "$BIN" synth --out "$S" --points "$N" --targets 8 --decoys 10 --seed 21 \
    --spread-m 120 --yaw-deg 237 --offset-m 10000,-10000,20 --tilt-deg 8 \
    --survey-false-origin-m 352000,4026000,0 --format "$FORMAT" >/dev/null
fi
MAP=$(ls "$S"/map.*)
python3 - "$S" > "$S/hints.csv" <<'PY'
import json, sys
t = json.load(open(sys.argv[1] + "/truth.json"))
print("id,x,y,z")
for x in t["targets"]:
    print("%s,%r,%r,%r" % (x["id"], x["map"][0], x["map"][1], x["map"][2]))
PY
cat "$MAP" > /dev/null
run() { # name, args...
  local name=$1; shift
  local out=$S/out-$name
  rm -rf "$out"
  local t0=$(date +%s%N)
  /usr/bin/time -f "%M" -o "$S/rss-$name" "$BIN" eval --map "$MAP" --survey "$S/survey.csv" \
    --out "$out" "$@" > /dev/null 2> "$S/err-$name"
  local t1=$(date +%s%N)
  echo "$(( (t1 - t0) / 1000000 )) $(cat "$S/rss-$name")"
}
declare -A wall rss
for r in $(seq "$RUNS"); do
  for k in given detect cat; do
    if [ "$k" = cat ]; then
      t0=$(date +%s%N); cat "$MAP" > /dev/null; t1=$(date +%s%N)
      wall[$k]+="$(( (t1 - t0) / 1000000 )) "; continue
    fi
    if [ "$k" = given ]; then res=$(run given --hints "$S/hints.csv"); else res=$(run detect --frame detect); fi
    wall[$k]+="${res%% *} "; rss[$k]="${res##* }"
  done
done
median() { tr ' ' '\n' | grep -v '^$' | sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
mg=$(echo "${wall[given]}" | median); md=$(echo "${wall[detect]}" | median); mc=$(echo "${wall[cat]}" | median)
echo "map: $MAP ($N points, $(du -h "$MAP" | cut -f1)), $RUNS rounds, $(nproc) cores"
printf "%-34s %8s %10s\n" "run" "wall ms" "peak RSS"
printf "%-34s %8s %10s\n" "cat" "$mc" "-"
printf "%-34s %8s %9sM\n" "eval given the transform (--hints)" "$mg" "$(( ${rss[given]} / 1024 ))"
printf "%-34s %8s %9sM\n" "eval finding the frame (detect)" "$md" "$(( ${rss[detect]} / 1024 ))"
awk -v d="$md" -v g="$mg" 'BEGIN {printf "detect / given = %.2f\n", d / g}'
grep -h "Found" "$S"/out-detect/../err-detect 2>/dev/null || true
python3 - "$S" <<'PY'
import json, sys
s = sys.argv[1]
for k in ("given", "detect"):
    r = json.load(open(f"{s}/out-{k}/result.json"))
    print(f"{k}: frame {r['eval']['frame']['how']}, found {r['absolute']['n']}/{len(r['targets'])}, E_abs {r['absolute']['mean']*1e3:.1f} mm")
PY
