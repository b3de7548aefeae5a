#!/usr/bin/env bash
# Benchmark of issue 2 item 7: `mapgauge crop` on a 20-million-point binary PCD
# against `cat FILE > /dev/null` with the file in the page cache, plus peak RSS.
#
# Usage: bench/crop_bench.sh [DIR]   (DIR default: /tmp/mapgauge-bench, outside the repo)
# Env:   POINTS (default 20000000), RUNS (default 3)
# Goal:  crop wall time <= 2 x cat wall time; crop peak RSS <= 200 MB.
set -euo pipefail

DIR=${1:-/tmp/mapgauge-bench}
POINTS=${POINTS:-20000000}
RUNS=${RUNS:-3}   # odd, for a plain median
REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

if [[ ! -x /usr/bin/time ]]; then
    echo "installing GNU time (/usr/bin/time is missing)" >&2
    if command -v apt-get >/dev/null; then
        SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO=sudo
        $SUDO apt-get install -y time >/dev/null
    else
        echo "error: /usr/bin/time is missing and apt-get is not available" >&2
        exit 1
    fi
fi

echo "building release..." >&2
(cd "$REPO" && cargo build --release --quiet)
BIN="$REPO/target/release/mapgauge"

MAP="$DIR/scene/map.pcd"
SURVEY="$DIR/scene/survey.csv"
if [[ -f "$MAP" && -f "$SURVEY" ]]; then
    echo "reusing $MAP" >&2
else
    echo "generating $POINTS points into $DIR/scene ..." >&2
    mkdir -p "$DIR"
    "$BIN" synth --points "$POINTS" --format pcd --out "$DIR/scene" >/dev/null
fi
BYTES=$(stat -c %s "$MAP")
NPTS=$(grep -a -m1 '^POINTS ' "$MAP" | awk '{print $2}')

# Wall clock in ms (GNU time's own %e has only 10 ms resolution; cat takes ~0.1 s).
now_ms() { echo $(( $(date +%s%N) / 1000000 )); }
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", (b - a) / 1000 }'; }
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }

cat "$MAP" >/dev/null                    # warm the page cache

# cat and crop alternate in each round so that both see the same machine load.
CATS=(); WALLS=(); RSS=(); LOG="$DIR/crop-time.log"
for i in $(seq 1 "$RUNS"); do
    t0=$(now_ms); cat "$MAP" >/dev/null; t1=$(now_ms)
    c=$(secs "$t0" "$t1"); CATS+=("$c")
    OUT="$DIR/out-$i"
    rm -rf "$OUT"
    t0=$(now_ms)
    /usr/bin/time -v "$BIN" crop --map "$MAP" --survey "$SURVEY" --out "$OUT" >/dev/null 2>"$LOG"
    t1=$(now_ms)
    w=$(secs "$t0" "$t1")
    r=$(grep 'Maximum resident set size' "$LOG" | awk '{print $NF}')
    WALLS+=("$w"); RSS+=("$r")
    echo "run $i: cat ${c} s, crop wall ${w} s, peak RSS $((r / 1024)) MB" >&2
done
CAT=$(median "${CATS[@]}")
CROP=$(median "${WALLS[@]}")
RSSMAX=$(printf '%s\n' "${RSS[@]}" | sort -n | tail -n1)
RATIO=$(awk -v c="$CROP" -v k="$CAT" 'BEGIN { if (k > 0) printf "%.2f", c / k; else print "inf" }')

echo
echo "machine:   $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "map:       $MAP ($NPTS points, $((BYTES / 1000000)) MB)"
echo "cat:       ${CAT} s median of $RUNS (runs: ${CATS[*]}; page cache warm)"
echo "crop:      ${CROP} s median of $RUNS (runs: ${WALLS[*]})"
echo "ratio:     crop/cat = ${RATIO}   (goal <= 2)"
echo "peak RSS:  $((RSSMAX / 1024)) MB   (goal <= 200 MB)"
awk -v c="$CROP" -v n="$NPTS" 'BEGIN { if (c > 0) printf "crop rate: %.0f M points/s\n", n / c / 1e6 }'
