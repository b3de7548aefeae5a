#!/usr/bin/env bash
# Checkpoints out (issue 35), read by GDAL's own tool: `ogrinfo` (Debian's
# gdal-bin, installed when missing) must open the GeoPackage and the GeoJSON
# that `eval --checkpoints` writes, with the right CRS, one feature per
# target, and the values of result.json; the surveyed points must be the
# survey CSV's own lat/lon (an independent source: the file the user gave).
#
#   ci/checkpoints_check.sh MAPGAUGE SCENE_DIR WORK_DIR
#
# SCENE_DIR is a `mapgauge synth` scene (map.ply, survey.csv, survey_llh.csv).
set -euo pipefail
bin=$1 scene=$2 work=$3
if ! command -v ogrinfo >/dev/null; then
    echo "checkpoints check: installing gdal-bin" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq --no-install-recommends gdal-bin >/dev/null
fi
ogrinfo --version
mkdir -p "$work"
# A WGS84 survey: EPSG:4979 (lon, lat, ellipsoidal height), GeoPackage and GeoJSON.
for f in cp.gpkg cp.geojson; do
    "$bin" eval --map "$scene/map.ply" --survey "$scene/survey_llh.csv" --dim 3d --align rigid3d \
        --out "$work/llh" --no-report --checkpoints "$work/$f" >/dev/null 2>"$work/$f.log" \
        || { cat "$work/$f.log" >&2; exit 1; }
done
# A projected survey with its EPSG code named (the synthetic site is near
# 127.36° E: UTM zone 52N).
"$bin" eval --map "$scene/map.ply" --survey "$scene/survey.csv" --no-report --out "$work/xy" \
    --checkpoints "$work/utm.gpkg" --checkpoints-crs EPSG:32652 >/dev/null 2>"$work/utm.log" \
    || { cat "$work/utm.log" >&2; exit 1; }
for f in cp.gpkg cp.geojson utm.gpkg; do
    ogrinfo -ro -al "$work/$f" >"$work/$f.txt" 2>"$work/$f.err" || { cat "$work/$f.err" >&2; exit 1; }
done
python3 - "$work" "$scene/survey_llh.csv" <<'PY'
import csv, json, re, sys
work, llh = sys.argv[1], sys.argv[2]

def features(text):
    """ogrinfo -al's features: {field: value} with the geometry as 'geom'."""
    out, cur = [], None
    for line in text.splitlines():
        if line.startswith("OGRFeature("):
            cur = {}
            out.append(cur)
        elif cur is not None:
            m = re.match(r"\s+(\w+) \((\w+)\) = (.*)$", line)
            if m:
                cur[m.group(1)] = m.group(3)
            elif line.strip().startswith("POINT"):
                cur["geom"] = [float(v) for v in re.findall(r"-?\d+\.?\d*(?:e-?\d+)?", line)]
    return out

def check(name, result, srs, want_geom):
    text = open(f"{work}/{name}.txt").read()
    r = json.load(open(result))
    n = len(r["targets"])
    count = int(re.search(r"Feature Count: (\d+)", text).group(1))
    assert count == n, f"{name}: {count} features for {n} targets"
    assert srs in text, f"{name}: the layer's CRS is not {srs}"
    feats = features(text)
    assert len(feats) == n, f"{name}: read {len(feats)} features"
    for t, f in zip(r["targets"], feats):
        assert f["id"] == t["id"] and f["status"] == t["status"], (name, f, t["id"])
        if t["aligned"] is None:
            assert f["dx_m"] == "(null)", (name, f)
            continue
        dx = t["aligned"]["x"] - t["survey"]["x"]
        assert abs(float(f["dx_m"]) - dx) < 1e-9, (name, f["dx_m"], dx)
        assert abs(float(f["error_m"]) - t["abs_error"]) < 1e-9, (name, f["error_m"])
        want_geom(t, f["geom"])
    print(f"{name}: {count} features, CRS {srs}, values = result.json")

# Every surveyed point at the survey CSV's own lat/lon, its height the
# antenna's minus the antenna height.
rows = {r["id"]: r for r in csv.DictReader(open(llh))}
def at_llh(t, g):
    s = rows[t["id"]]
    assert abs(g[0] - float(s["lon"])) < 1e-9 and abs(g[1] - float(s["lat"])) < 1e-9, (t["id"], g, s)
    h = float(s["alt"]) - float(s.get("antenna_height") or 0)
    assert abs(g[2] - h) < 1e-4, (t["id"], g[2], h)
def at_xy(t, g):
    assert abs(g[0] - t["survey"]["x"]) < 1e-9 and abs(g[1] - t["survey"]["y"]) < 1e-9, (t["id"], g)

check("cp.gpkg", f"{work}/llh/result.json", 'ID["EPSG",4979]', at_llh)
check("cp.geojson", f"{work}/llh/result.json", 'GEOGCRS["WGS 84"', at_llh)
check("utm.gpkg", f"{work}/xy/result.json", "UTM zone 52N", at_xy)
PY
