#!/usr/bin/env bash
# Tests ci/browser_check.sh itself: the intact report must pass, and each
# deliberately broken copy must fail with the expected reason.
# Usage: ci/browser_check_test.sh REPORT.html RESULT.json (a real eval report,
# e.g. the demo's; .ci/run passes it).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
report=$(realpath "$1")
result=$(realpath "$2")
# A page of a run given --trajectory has the route's figure too.
route=$(grep -q 'id="fig-error-route"' "$report" && echo route || true)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0

# case NAME EXPECT PYTHON-EDIT: copies the report into its own directory, edits
# it (`s` is the page, `r` result.json as a dict), runs the check, and wants
# exit 0 for EXPECT=pass, or exit 1 with EXPECT in its stderr.
case_() {
    local name=$1 expect=$2 edit=$3 dir="$work/$1"
    mkdir -p "$dir"
    python3 - "$report" "$result" "$dir" "$edit" <<'PY'
import json, re, shutil, sys
report, result, d, edit = sys.argv[1:]
s = open(report, encoding="utf-8").read()
r = json.load(open(result, encoding="utf-8"))
exec(edit)
open(d + "/report.html", "w", encoding="utf-8").write(s)
json.dump(r, open(d + "/result.json", "w"))
PY
    local rc=0
    bash "$here/browser_check.sh" "$dir/report.html" "$dir/shot.png" "$dir/result.json" $route \
        >"$dir/out" 2>"$dir/err" || rc=$?
    if [ "$expect" = pass ]; then
        [ "$rc" = 0 ] && { echo "ok   $name: passes"; return; }
    elif [ "$rc" = 1 ] && grep -qF -- "$expect" "$dir/err"; then
        echo "ok   $name: fails ($(grep -F -- "$expect" "$dir/err" | head -1 | sed 's/^browser check FAILED: //'))"
        return
    fi
    echo "FAIL $name: want ${expect}, got exit $rc:" >&2
    cat "$dir/out" "$dir/err" >&2
    failures=$((failures + 1))
}

case_ intact pass 'pass'
# One target figure gone, the page's own count lowered to match (what the old
# check compared with).
case_ missing-target-figure 'result.json implies' '
s, n = re.subn(r"<figure id=\"fig-target-[^\"]*\".*?</figure>", "", s, count=1, flags=re.S)
assert n == 1
s = re.sub(r"(mapgauge-figures\" content=\")(\d+)", lambda m: m.group(1) + str(int(m.group(2)) - 1), s)'
case_ no-figures 'result.json implies' '
s = re.sub(r"<figure id=.*?</figure>", "", s, flags=re.S)
s = re.sub(r"(mapgauge-figures\" content=\")\d+", r"\g<1>0", s)'
# A target the run could not locate still has its figure: result.json with one
# more target than the page shows fails.
case_ target-without-figure 'target figures, result.json has' '
t = dict(r["targets"][0]); t["id"] = "extra"; t["status"] = "not_found"; r["targets"].append(t)'
case_ http-image 'failed to load: img http://' '
s = s.replace("<body>", "<body><img src=\"http://example.invalid/logo.png\" alt=\"\">", 1)'
case_ missing-local-image 'failed to load: img file://' '
s = s.replace("<body>", "<body><img src=\"logo.png\" alt=\"\">", 1)'
# A file beside the report loads, but the page is no longer self-contained.
case_ local-stylesheet 'outside the page' '
open(d + "/extra.css", "w").write("body { margin: 0 }")
s = s.replace("</head>", "<link rel=\"stylesheet\" href=\"extra.css\"></head>", 1)'
case_ css-background-http 'outside the page: <css> http://' '
s = s.replace("</head>", "<style>body { background: url(http://example.invalid/bg.png) }</style></head>", 1)'
case_ script-error 'console' '
s = s.replace("</body>", "<script>undefinedFunction()</script></body>", 1)'
# A table wider than the page at 1280 px (as the paper's Table I of 12 targets was).
case_ wide-table 'overflows its section' '
s = s.replace("<h3>Statistics</h3>", "<h3>Wide</h3><div class=\"scroll\"><table class=\"grid\"><tr>" + "<td>0.0123</td>" * 120 + "</tr></table></div><h3>Statistics</h3>", 1)'
# A figure whose tick labels are gone but one: no scale.
case_ single-tick 'labelled x ticks' '
i = s.index("<figure id=\"fig-overview\"")
j = s.index("</figure>", i)
k = [0]
def keep_one(m):
    k[0] += 1
    return m.group(0) if k[0] == 1 else ""
s = s[:i] + re.sub(r"<text[^>]*>-?[0-9.]+</text>", keep_one, s[i:j]) + s[j:]'
# Two tick labels drawn on top of each other.
case_ overlapping-ticks 'tick labels overlap' '
i = s.index("<figure id=\"fig-relative\"")
j = s.index("</figure>", i)
m = list(re.finditer(r"<text x=\"([0-9.]+)\"([^>]*)>(-?[0-9.]+)</text>", s[i:j]))
a, b = m[0], m[1]
moved = "<text x=\"" + str(float(a.group(1)) + 3) + "\"" + b.group(2) + ">" + b.group(3) + "</text>"
seg = s[i:j]
seg = seg[:b.start()] + moved + seg[b.end():]
s = s[:i] + seg + s[j:]'
case_ blank-page 'blank page' '
s = re.sub(r"<body>.*</body>", "<body></body>", s, flags=re.S)'

if [ "$failures" -gt 0 ]; then
    echo "browser check self-test: $failures case(s) wrong" >&2
    exit 1
fi
echo "browser check self-test: ok"
