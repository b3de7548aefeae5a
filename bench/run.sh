#!/usr/bin/env bash
# Side-by-side benchmark of issue 7: mapgauge crop / eval against `cat` (the
# floor: one copy of the page-cached file), Open3D (PyPI `open3d`: read + numpy
# mask per target + write), PCL's command-line tools (Debian `pcl-tools`:
# pcl_passthrough_filter on x then y per target), laspy for LAS/LAZ/COPC (PyPI
# `laspy[lazrs]`: read + numpy mask per target + write) and PDAL's
# filters.crop (`pdal pipeline`, where PDAL is installed), on synthetic maps in
# every format. Wall time, CPU time (user + sys) and peak RSS, median of RUNS rounds;
# tools alternate inside each round so they all see the same machine load.
#
# Usage: bench/run.sh [POINTS...]          (default: 20000000)
#        bench/run.sh 2000000              quick mode, about a minute
#        bench/run.sh 20000000 200000000   the issue's sizes (200 M: ~25 GB of disk)
# Env:   DIR      data directory, outside the repo   (default /tmp/mapgauge-bench)
#        RUNS     rounds per measurement, odd        (default 3)
#        FORMATS  subset of: pcd pcd-ascii pcd-compressed ply las laz
#                 pcd-xyzi pcd-fastlio ply-f32 (the float32 SLAM layouts:
#                 LIO-SAM's x y z intensity, FAST-LIO2's eight floats, GLIM's
#                 float PLY; synthesised directly in that layout)
#                 laz14 (LAS 1.4 point format 6 LAZ, every field varying:
#                 bench/laz14_write.py, needs laspy), copc (bench/copc_write.py,
#                 copclib in a venv made in DIR), tiles (an Autoware tiled map
#                 of 20 m PCD tiles: bench/tiles_write.py)
#        TOOLS    subset of: cat crop floor eval open3d pcl laspy pdal
#                 (floor: `cat` of the map, then the bytes of the crops `crop`
#                 just wrote copied into one new file: the reading and writing
#                 any crop must do, without the parsing; after `crop` only)
#        BASELINE_MAX_POINTS  largest map given to Open3D and PCL (default 50000000:
#                 they hold the whole map in memory, ~10 GB at 200 M points)
#        BIN      a mapgauge binary to measure instead of this checkout's
#                 release build (an older build, for a before/after)
#        OUT      markdown table file (default DIR/results-<date>.md), headed by
#                 the build's commit (-dirty: uncommitted changes built in) and the
#                 machine (cores, CPU model, memory, load average before and after)
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
DIR=${DIR:-/tmp/mapgauge-bench}
RUNS=${RUNS:-3}
FORMATS=${FORMATS:-"pcd pcd-ascii pcd-compressed ply las laz laz14 copc tiles pcd-xyzi pcd-fastlio ply-f32"}
TOOLS=${TOOLS:-"cat crop floor eval open3d pcl laspy pdal"}
BASELINE_MAX_POINTS=${BASELINE_MAX_POINTS:-50000000}
SIZES=("$@")
[[ ${#SIZES[@]} -eq 0 ]] && SIZES=(20000000)
mkdir -p "$DIR"
OUT=${OUT:-$DIR/results-$(date -u +%Y%m%dT%H%M%S).md}
NOTES=()
note() { NOTES+=("$1"); echo "note: $1" >&2; }

if [[ ! -x /usr/bin/time ]]; then
    echo "installing GNU time" >&2
    apt-get install -y time >/dev/null 2>&1 || { echo "error: /usr/bin/time missing" >&2; exit 1; }
fi
if [[ -n "${BIN:-}" ]]; then
    echo "benchmarking $BIN (not built here)" >&2
else
    echo "building release..." >&2
    (cd "$REPO" && cargo build --release --quiet)
    BIN="$REPO/target/release/mapgauge"
fi

have_open3d=0
if python3 -c 'import open3d' 2>/dev/null; then have_open3d=1
elif [[ " $TOOLS " == *" open3d "* ]]; then note "Open3D skipped: python3 cannot import open3d (pip install open3d)"; fi
have_pcl=0
if command -v pcl_passthrough_filter >/dev/null; then have_pcl=1
elif [[ " $TOOLS " == *" pcl "* ]]; then note "PCL skipped: pcl_passthrough_filter missing (apt-get install pcl-tools)"; fi
have_laspy=0
if python3 -c 'import laspy, lazrs' 2>/dev/null; then have_laspy=1
elif [[ " $TOOLS $FORMATS " == *" laspy "* || " $FORMATS " == *" laz14 "* ]]; then
    note "laspy skipped (and the laz14 format, which it writes): python3 cannot import laspy and lazrs (pip install 'laspy[lazrs]')"; fi
have_pdal=0
if command -v pdal >/dev/null; then have_pdal=1
elif [[ " $TOOLS " == *" pdal "* ]]; then note "PDAL skipped: no pdal command (apt-get install pdal; PyPI's pdal is bindings that need it)"; fi

now_ns() { date +%s%N; }
median() { printf '%s\n' "$@" | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
max() { printf '%s\n' "$@" | sort -g | tail -n1; }

# run_one KEY CMD...: one timed run; appends wall, cpu, rss to KEY's lists.
declare -A WALL CPU RSS READ
run_one() {
    local key=$1; shift
    local tf; tf=$(mktemp)
    local t0 t1
    t0=$(now_ns)
    if ! /usr/bin/time -f "%U %S %M" -o "$tf" "$@" >/dev/null 2>"$tf.err"; then
        echo "warning: $key failed: $(tail -n2 "$tf.err" | tr '\n' ' ')" >&2
        WALL[$key]+="nan "; CPU[$key]+="nan "; RSS[$key]+="0 "
        rm -f "$tf" "$tf.err"; return
    fi
    t1=$(now_ns)
    read -r u s m < <(tail -n1 "$tf")
    # `crop` on a tiled map or COPC: "tiles: 12 of 118 opened (3.0 of 5.1 MB)".
    READ[$key]=$(grep -m1 -E '^(tiles|COPC nodes): .* opened' "$tf.err" | sed 's/ opened//' || true)
    WALL[$key]+="$(awk -v a="$t0" -v b="$t1" 'BEGIN{printf "%.3f", (b-a)/1e9}') "
    CPU[$key]+="$(awk -v u="$u" -v s="$s" 'BEGIN{printf "%.2f", u+s}') "
    RSS[$key]+="$m "
    rm -f "$tf" "$tf.err"
}

# pcl_crop MAP SURVEY OUTDIR: per target, x range then y range (a 2r box).
pcl_crop() {
    local map=$1 survey=$2 out=$3 r=5
    mkdir -p "$out"
    tail -n +2 "$survey" | while IFS=, read -r id x y _rest; do
        pcl_passthrough_filter "$map" "$out/$id-x.pcd" -field x -min "$(awk -v a="$x" -v r=$r 'BEGIN{print a-r}')" \
            -max "$(awk -v a="$x" -v r=$r 'BEGIN{print a+r}')" -keep 0 >/dev/null
        pcl_passthrough_filter "$out/$id-x.pcd" "$out/$id.pcd" -field y -min "$(awk -v a="$y" -v r=$r 'BEGIN{print a-r}')" \
            -max "$(awk -v a="$y" -v r=$r 'BEGIN{print a+r}')" -keep 0 >/dev/null
        rm -f "$out/$id-x.pcd"
    done
}
export -f pcl_crop

# pdal_crop MAP SURVEY OUTDIR: PDAL's filters.crop, one r-metre circle (a
# cylinder) per target, each written by writers.las as its own file.
pdal_crop() {
    local map=$1 survey=$2 out=$3 r=5 pts
    mkdir -p "$out"
    pts=$(tail -n +2 "$survey" | awk -F, '{printf "%s\"POINT(%s %s)\"", (NR>1?",":""), $2, $3}')
    printf '[{"type":"%s","filename":"%s"},{"type":"filters.crop","point":[%s],"distance":%s},{"type":"writers.las","filename":"%s/#.las"}]\n' \
        "$4" "$map" "$pts" "$r" "$out" >"$out.json"
    pdal pipeline "$out.json"
}
export -f pdal_crop

# What was measured and on what: the table is only comparable with tables of
# the same build and machine, so both head it.
COMMIT=$(git -C "$REPO" rev-parse --short HEAD 2>/dev/null || echo unknown)
# Uncommitted changes (tracked or not) went into the build too.
if [[ $COMMIT != unknown && -n $(git -C "$REPO" status --porcelain 2>/dev/null) ]]; then
    COMMIT="$COMMIT-dirty"
fi
# A binary given as BIN is its own build, whatever this checkout holds.
[[ "$BIN" != "$REPO/target/release/mapgauge" ]] && COMMIT="unknown (BIN=$BIN)"
CPU_MODEL=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//' || true)
CPU_MODEL=${CPU_MODEL:-$(grep -m1 vendor_id /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//' || true)}
CPU_MODEL=${CPU_MODEL:-unknown CPU}
HYPERVISOR=$(lscpu 2>/dev/null | sed -n 's/^Hypervisor vendor: *//p' || true)
{
echo "# mapgauge benchmark $(date -u +%Y-%m-%dT%H:%MZ)"
echo
echo "- Build: mapgauge $("$BIN" --version 2>/dev/null | awk '{print $2}') at commit $COMMIT, \`cargo build --release\`, $(rustc --version 2>/dev/null || echo 'rustc ?')."
echo "- Machine: $(nproc) cores ($CPU_MODEL${HYPERVISOR:+, $HYPERVISOR guest}), $(awk '/MemTotal/ {printf "%.1f GB", $2/1048576}' /proc/meminfo) RAM, Linux $(uname -r)."
echo "- Load average (1, 5, 15 min) before: $(cut -d' ' -f1-3 /proc/loadavg)."
echo "- Median of $RUNS runs; files in the page cache; CPU = user + sys; peak RSS from GNU time."
echo
echo "| points | format | MB | tool | wall s | CPU s | peak RSS MB | wall / cat | CPU / cat | wall / floor | Open3D wall / this | read |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
} >"$OUT"

for N in "${SIZES[@]}"; do
    S="$DIR/n$N"
    mkdir -p "$S"
    if [[ ! -f "$S/map.pcd" || ! -f "$S/survey.csv" ]]; then
        echo "synthesising $N points into $S ..." >&2
        "$BIN" synth --points "$N" --format pcd --out "$S" >/dev/null
    fi
    NPTS=$(grep -a -m1 '^POINTS ' "$S/map.pcd" | awk '{print $2}')
    declare -A FILE=([pcd]="$S/map.pcd" [pcd-ascii]="$S/map-ascii.pcd" [pcd-compressed]="$S/map-compressed.pcd"
                     [ply]="$S/map.ply" [las]="$S/map.las" [laz]="$S/map.laz"
                     [laz14]="$S/map14.laz" [copc]="$S/map.copc.laz" [tiles]="$S/tiles"
                     [pcd-xyzi]="$S/pcd-xyzi/map.pcd" [pcd-fastlio]="$S/pcd-fastlio/map.pcd" [ply-f32]="$S/ply-f32/map.ply")
    # The survey of every layout: the scene (and so the survey) does not
    # depend on the format the map is written in.
    declare -A SURVEY=()
    for f in $FORMATS; do
        [[ -n ${FILE[$f]:-} ]] || { note "unknown format $f"; continue; }
        SURVEY[$f]="$S/survey.csv"
        if [[ $f == pcd-xyzi || $f == pcd-fastlio || $f == ply-f32 ]]; then
            # float32 layouts carry intensity (and FAST-LIO2's normals): a
            # conversion from the double map could not fill them, so synth
            # writes them directly.
            SURVEY[$f]="$S/$f/survey.csv"
            if [[ ! -f ${FILE[$f]} || ! -f ${SURVEY[$f]} ]]; then
                echo "synthesising $N points as $f ..." >&2
                "$BIN" synth --points "$N" --format "$f" --out "$S/$f" >/dev/null
            fi
            continue
        fi
        if [[ $f == laz14 || $f == copc || $f == tiles ]]; then
            [[ -e ${FILE[$f]} ]] && continue
            if [[ $f != tiles && ! -f ${FILE[las]} ]]; then
                echo "converting to las (for $f) ..." >&2
                "$BIN" convert --map "$S/map.pcd" --out "${FILE[las]}" >/dev/null
            fi
            echo "writing $f ..." >&2
            case $f in
                laz14) if [[ $have_laspy == 1 ]]; then python3 "$REPO/bench/laz14_write.py" "${FILE[las]}" "${FILE[$f]}" 6
                       else note "laz14 skipped: it is written with laspy"; fi ;;
                copc)  if [[ -z ${COPC_PY:-} ]]; then
                           COPC_PY=$DIR/venv-copc/bin/python
                           [[ -x $COPC_PY ]] || { python3 -m venv "$DIR/venv-copc" && "$DIR/venv-copc/bin/pip" install --quiet copclib==2.6.3 numpy; } || true
                       fi
                       COPC_LEAF=0 "$COPC_PY" "$REPO/bench/copc_write.py" "${FILE[las]}" "${FILE[$f]}" \
                           || { rm -f "${FILE[$f]}"; note "copc skipped: copclib (PyPI copclib==2.6.3) could not write it"; } ;;
                tiles) python3 "$REPO/bench/tiles_write.py" "$S/map.pcd" "${FILE[$f]}" 20 ;;
            esac
            continue
        fi
        if [[ ! -f ${FILE[$f]} ]]; then
            if [[ $f == pcd-compressed ]] && (( NPTS * 24 > 4294967295 )); then
                note "$N points: binary_compressed PCD skipped: the format's 32-bit sizes cannot hold $NPTS double points"
                continue
            fi
            echo "converting to $f ..." >&2
            "$BIN" convert --map "$S/map.pcd" --out "${FILE[$f]}" --format "$f" >/dev/null
        fi
    done
    # PCL's filters read fields as float32: give them float32 copies.
    declare -A PCLFILE=([pcd]="$S/map-f32.pcd" [pcd-ascii]="$S/map-f32-ascii.pcd" [pcd-compressed]="$S/map-f32-compressed.pcd"
                        [pcd-xyzi]="${FILE[pcd-xyzi]}" [pcd-fastlio]="${FILE[pcd-fastlio]}")
    if [[ " $TOOLS " == *" pcl "* && $have_pcl == 1 ]] && (( NPTS <= BASELINE_MAX_POINTS )); then
        [[ -f ${PCLFILE[pcd]} ]] || python3 "$REPO/bench/pcd_f32.py" "$S/map.pcd" "${PCLFILE[pcd]}"
        [[ -f ${PCLFILE[pcd-ascii]} ]] || pcl_convert_pcd_ascii_binary "${PCLFILE[pcd]}" "${PCLFILE[pcd-ascii]}" 0 >/dev/null
        [[ -f ${PCLFILE[pcd-compressed]} ]] || pcl_convert_pcd_ascii_binary "${PCLFILE[pcd]}" "${PCLFILE[pcd-compressed]}" 2 >/dev/null
    fi
    for f in $FORMATS; do
        MAP=${FILE[$f]:-}
        [[ -n $MAP && -e $MAP ]] || continue
        # A tiled map is a folder: its bytes are its tiles', and `cat` reads them all.
        CATS=("$MAP")
        [[ -d $MAP ]] && CATS=("$MAP"/*.pcd)
        MB=$(( $(cat "${CATS[@]}" | wc -c) / 1000000 ))
        cat "${CATS[@]}" >/dev/null   # warm the page cache
        [[ -f ${PCLFILE[$f]:-/nonexistent} && ${PCLFILE[$f]} != "$MAP" ]] && cat "${PCLFILE[$f]}" >/dev/null
        tools=()
        for t in $TOOLS; do
            case $t in
                open3d) [[ $have_open3d == 1 ]] || continue
                        [[ $f == las || $f == laz || $f == laz14 || $f == copc ]] && { note "Open3D cannot read $f"; continue; }
                        [[ $f == tiles ]] && { note "Open3D cannot read a tiled map (a folder)"; continue; }
                        (( NPTS > BASELINE_MAX_POINTS )) && { note "$N points: Open3D skipped (BASELINE_MAX_POINTS)"; continue; } ;;
                pcl)    [[ $have_pcl == 1 ]] || continue
                        [[ $f == pcd* ]] || continue
                        (( NPTS > BASELINE_MAX_POINTS )) && { note "$N points: PCL skipped (BASELINE_MAX_POINTS)"; continue; } ;;
                laspy)  [[ $have_laspy == 1 ]] || continue
                        [[ $f == las || $f == laz || $f == laz14 || $f == copc ]] || continue
                        (( NPTS > BASELINE_MAX_POINTS )) && { note "$N points: laspy skipped (BASELINE_MAX_POINTS)"; continue; } ;;
                floor)  [[ " $TOOLS " == *" crop "* ]] || { note "floor skipped: it copies the crops \`crop\` wrote, and crop is not in TOOLS"; continue; } ;;
                pdal)   [[ $have_pdal == 1 ]] || continue
                        [[ $f == las || $f == laz || $f == laz14 || $f == copc || $f == pcd || $f == ply ]] || continue ;;
            esac
            tools+=("$t")
        done
        for i in $(seq 1 "$RUNS"); do
            for t in "${tools[@]}"; do
                key="$N|$f|$t"
                rm -rf "$S/out-$t"
                echo "  $N $f $t run $i" >&2
                case $t in
                    cat)    run_one "$key" cat "${CATS[@]}" ;;
                    crop)   run_one "$key" "$BIN" crop --map "$MAP" --survey "${SURVEY[$f]}" --out "$S/out-$t" ;;
                    floor)  mkdir -p "$S/out-floor"
                            run_one "$key" bash -c 'd=$0 o=$1; shift; cat "$@" >/dev/null && cat "$d"/* >"$o"' \
                                "$S/out-crop" "$S/out-floor/crops" "${CATS[@]}" ;;
                    eval)   run_one "$key" "$BIN" eval --map "$MAP" --survey "${SURVEY[$f]}" --out "$S/out-$t" ;;
                    open3d) run_one "$key" python3 "$REPO/bench/open3d_crop.py" "$MAP" "${SURVEY[$f]}" "$S/out-$t" ;;
                    pcl)    run_one "$key" bash -c "pcl_crop '${PCLFILE[$f]}' '${SURVEY[$f]}' '$S/out-$t'" ;;
                    laspy)  run_one "$key" python3 "$REPO/bench/laspy_crop.py" "$MAP" "${SURVEY[$f]}" "$S/out-$t" ;;
                    pdal)   reader=readers.las
                            [[ $f == copc ]] && reader=readers.copc
                            [[ $f == pcd ]] && reader=readers.pcd
                            [[ $f == ply ]] && reader=readers.ply
                            run_one "$key" bash -c "pdal_crop '$MAP' '${SURVEY[$f]}' '$S/out-$t' $reader" ;;
                esac
            done
        done
        catw=$(median ${WALL["$N|$f|cat"]:-nan})
        catc=$(median ${CPU["$N|$f|cat"]:-nan})
        o3w=$(median ${WALL["$N|$f|open3d"]:-nan})
        flw=$(median ${WALL["$N|$f|floor"]:-nan})
        for t in "${tools[@]}"; do
            key="$N|$f|$t"
            w=$(median ${WALL[$key]}); c=$(median ${CPU[$key]}); r=$(( $(max ${RSS[$key]}) / 1024 ))
            rw=$(awk -v a="$w" -v b="$catw" 'BEGIN{ if (b+0 > 0 && a != "nan") printf "%.2f", a/b; else print "-" }')
            rc=$(awk -v a="$c" -v b="$catc" 'BEGIN{ if (b+0 > 0 && a != "nan") printf "%.2f", a/b; else print "-" }')
            ro=$(awk -v a="$o3w" -v b="$w" 'BEGIN{ if (a != "nan" && b+0 > 0) printf "%.1f", a/b; else print "-" }')
            rf=$(awk -v a="$w" -v b="$flw" 'BEGIN{ if (b != "nan" && b+0 > 0 && a != "nan") printf "%.2f", a/b; else print "-" }')
            mb=$MB; name=$t
            if [[ $t == pcl && ${PCLFILE[$f]} != "$MAP" ]]; then mb="$(( $(stat -c %s "${PCLFILE[$f]}") / 1000000 ))"; name="pcl (float32 copy)"; fi
            rd=${READ[$key]:-}
            [[ -n $rd ]] || rd="-"
            echo "| $NPTS | $f | $mb | $name | $w | $c | $r | $rw | $rc | $rf | $ro | $rd |" >>"$OUT"
            echo "$NPTS $f $t: wall ${WALL[$key]}cpu ${CPU[$key]}rss ${RSS[$key]}" >&2
        done
    done
done

{
echo
echo "Load average after: $(cut -d' ' -f1-3 /proc/loadavg)."
for n in "${NOTES[@]}"; do echo "- $n"; done | sort -u
} >>"$OUT"
cat "$OUT"
