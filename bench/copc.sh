#!/usr/bin/env bash
# COPC crop against decoding the whole LAZ (issue 21): `mapgauge crop` of 8
# targets (5 m cylinders) in a random 400 m x 400 m x 20 m cloud written as
# COPC by copclib (bench/copc_write.py with COPC_MAX_NODE=2000: the depth is
# chosen for 2 000 points a node of the whole octree cube, which this flat
# cloud fills a twentieth of, so nodes hold ~11 k points at 200 M), and of
# the very same file with its COPC VLR renamed, which mapgauge then reads as
# plain LAZ (every chunk, in file order). Page-cached files; wall time and
# peak RSS are the median of RUNS runs; the crops of both must be identical
# byte for byte (the script fails otherwise).
#
# With SCENE=synth, the cloud is instead a `mapgauge synth` scene (5 targets,
# written as LAS, then as COPC by the same script) and the rows are `crop`
# and `eval` of its survey on the COPC file (issue 29: eval reads the ground
# sample and the crops' nodes only): wall, CPU and bytes read per pass.
# That COPC's octree is adaptive, as real writers build it (COPC_LEAF=100000:
# no node holds more than about 100 k points; a split node keeps about
# 16 k). COPC_LEAF=0 writes it with the fixed depth of the random cloud
# instead (COPC_MAX_NODE=2000), whose deepest nodes under this scene's
# dense strip hold up to 2.3 M points each (the 6 Dec rows).
#
# Usage: bench/copc.sh [POINTS]        (default 20000000; 50 M: ~350 MB of disk)
# Env:   DIR   data directory (default /tmp/mapgauge-copc)
#        SCENE random (default) or synth (200 M: ~4 GB of LAS beside the COPC)
#        RUNS  runs per measurement, odd (default 3)
#        PY    a python with copclib and numpy (default: a venv made in DIR
#              with `pip install copclib==2.6.3 numpy`)
#        COPC_LEAF  with SCENE=synth: split octree nodes past this many
#              points (default 100000; 0: one depth, COPC_MAX_NODE=2000)
#        COPC_NODE_KEEP  points a split node keeps (default 16384)
#        BIN   a mapgauge binary to time as it is (default: cargo build
#              --release, then target/release/mapgauge)
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
N=${1:-20000000}
DIR=${DIR:-/tmp/mapgauge-copc}
RUNS=${RUNS:-3}
mkdir -p "$DIR"
if [[ -z ${BIN:-} ]]; then
    BIN=$REPO/target/release/mapgauge
    (cd "$REPO" && cargo build --release --quiet)
fi
if [[ -z ${PY:-} ]]; then
    if [[ ! -x $DIR/venv/bin/python ]]; then
        python3 -m venv "$DIR/venv"
        "$DIR/venv/bin/pip" install --quiet copclib==2.6.3 numpy
    fi
    PY=$DIR/venv/bin/python
fi
median() { sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

case ${SCENE:-random} in
    random | synth) ;;
    *) echo "SCENE is random or synth, not ${SCENE}" >&2; exit 2 ;;
esac
if [[ ${SCENE:-random} == synth ]]; then
    scene=$DIR/synth$N
    leaf=${COPC_LEAF:-100000}
    copc=$DIR/synth$N.copc.laz
    [[ $leaf == 0 ]] || copc=$DIR/synth$N-leaf$leaf${COPC_NODE_KEEP:+-keep$COPC_NODE_KEEP}.copc.laz
    [[ -s $scene/map.las ]] || "$BIN" synth --points "$N" --format las --out "$scene" >/dev/null
    # Written under another name first: an interrupted writer leaves no file
    # a later run would take for a whole one (synth renames its own at the end).
    if [[ ! -s $copc ]]; then
        COPC_LEAF=$leaf COPC_MAX_NODE=${COPC_MAX_NODE:-2000} "$PY" "$REPO/bench/copc_write.py" "$scene/map.las" "$copc.partial"
        mv "$copc.partial" "$copc"
    fi
    cat "$copc" >/dev/null
    echo "| tool | points | wall s | CPU s | RSS MB | read |"
    echo "| --- | ---: | ---: | ---: | ---: | --- |"
    for tool in crop eval "eval --no-report"; do
        times=() cpus=() rss=()
        for ((r = 0; r < RUNS; r++)); do
            rm -rf "$DIR/out-synth"
            # shellcheck disable=SC2086
            /usr/bin/time -f '%e %U %S %M' -o "$DIR/time-synth" \
                "$BIN" $tool --map "$copc" --survey "$scene/survey.csv" --out "$DIR/out-synth" \
                >/dev/null 2>"$DIR/err-synth" ||
                { echo "mapgauge $tool failed:" >&2; tail -5 "$DIR/err-synth" >&2; exit 1; }
            read -r t u s m <"$DIR/time-synth"
            times+=("$t")
            cpus+=("$(awk -v u="$u" -v s="$s" 'BEGIN { print u + s }')")
            rss+=("$m")
        done
        read_=$(grep -o 'COPC nodes: .*' "$DIR/err-synth" || true)
        if [[ -s $DIR/out-synth/result.json ]]; then
            read_=$("$PY" -c 'import json,sys; r=json.load(open(sys.argv[1]))["eval"]["reads"]; print("; ".join("%s: %d points, %.1f MB" % (p["pass"], p["points"], p["bytes"] / 1e6) for p in r))' "$DIR/out-synth/result.json")
        fi
        printf '| %s | %s | %s | %s | %s | %s |\n' "$tool" "$N" \
            "$(printf '%s\n' "${times[@]}" | median)" "$(printf '%s\n' "${cpus[@]}" | median)" \
            "$(($(printf '%s\n' "${rss[@]}" | median) / 1024))" "$read_"
    done
    echo
    echo "file $(($(stat -L -c %s "$copc") / 1000000)) MB; $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
    exit 0
fi

copc=$DIR/r$N.copc.laz
plain=$DIR/r$N.plain.laz
[[ -s $copc ]] || COPC_LEAF=0 COPC_MAX_NODE=${COPC_MAX_NODE:-2000} "$PY" "$REPO/bench/copc_write.py" --random "$N" 3 "$copc"
if [[ ! -s $plain ]]; then
    cp "$copc" "$plain"
    # "copc" -> "xopc" in the first VLR's user id: no longer a COPC file.
    printf 'x' | dd of="$plain" bs=1 seek=377 conv=notrunc status=none
fi
survey=$DIR/survey.csv
{
    echo "id,x,y"
    for i in 0 1 2 3 4 5 6 7; do
        echo "T$i,$((350050 + i * 41)).5,$((4150060 + i * 37)).25"
    done
} >"$survey"
cat "$copc" "$plain" >/dev/null

row() { # label map
    local label=$1 map=$2 times=() rss=() r
    for ((r = 0; r < RUNS; r++)); do
        rm -rf "$DIR/out-$label"
        /usr/bin/time -f '%e %M' -o "$DIR/time-$label" \
            "$BIN" crop --map "$map" --survey "$survey" --out "$DIR/out-$label" \
            >/dev/null 2>"$DIR/err-$label"
        read -r t m <"$DIR/time-$label"
        times+=("$t")
        rss+=("$m")
    done
    local nodes
    nodes=$(grep -o 'COPC nodes: .*' "$DIR/err-$label" || echo "every chunk ($(du -m "$map" | cut -f1) MB)")
    printf '| %s | %s | %s | %s | %s |\n' "$label" "$N" \
        "$(printf '%s\n' "${times[@]}" | median)" \
        "$(($(printf '%s\n' "${rss[@]}" | median) / 1024))" "$nodes"
}

echo "| read | points | wall s | RSS MB | read |"
echo "| --- | ---: | ---: | ---: | --- |"
row copc "$copc"
row plain "$plain"
diff -r "$DIR/out-copc" "$DIR/out-plain" >/dev/null ||
    { echo "crops differ between COPC and plain LAZ" >&2; exit 1; }
echo
echo "crops identical ($(ls "$DIR/out-copc" | wc -l) files); $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
