#!/usr/bin/env bash
# Renders a report.html in headless Chromium and fails on a console message, a
# resource that fails to load or comes from outside the page (the report is one
# self-contained file), a blank page, a figure count other than the one
# result.json implies (overview + relative + error CDF + one per target, found
# or not; + error along the route when the 4th argument is `route`), a
# table that runs off the page at 1280 px, or a plot frame without at least two
# labelled ticks on each axis.
# Usage: ci/browser_check.sh REPORT.html [SCREENSHOT.png] [RESULT.json] [route]
# (RESULT.json defaults to the one beside the report). The page a run that
# could not score writes is checked against its failed.csv instead (given as
# the third argument): one figure per surveyed place. ci/browser_check_test.sh
# runs it against deliberately broken pages.
# Installs Debian's chromium (and python3) when missing (CI runs as root).
set -euo pipefail
report=$(realpath "$1")
shot=${2:-$(dirname "$report")/report.png}
shot=$(realpath -m "$shot")
result=$(realpath -m "${3:-$(dirname "$report")/result.json}")
route=${4:-}
[ -s "$result" ] || { echo "browser check: no result.json (or failed.csv) at $result" >&2; exit 1; }

missing=()
[ -x /usr/bin/chromium ] || missing+=(chromium)
command -v python3 >/dev/null || missing+=(python3)
if [ ${#missing[@]} -gt 0 ]; then
    echo "browser check: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq "${missing[@]}" >/dev/null
fi

work=$(mktemp -d)
# A copy of the page beside it (so relative references resolve alike) with a
# probe first in <head>: it records every resource that fails to load (error
# events, captured at the window) or loads but is not an image it can decode,
# and every resource fetched at all, into the DOM once the page has loaded.
# The report itself has no script.
probe="$(dirname "$report")/.browser-check-$$.html"
trap 'rm -rf "$work" "$probe"' EXIT
python3 - "$report" "$probe" <<'PY'
import sys
src = open(sys.argv[1], encoding="utf-8").read()
js = """<script>(function () {
  var failed = [];
  function what(t) {
    var u = t.currentSrc || t.src || t.href || t.data || "";
    if (u && typeof u === "object") u = u.baseVal || "";
    return (t.tagName || "?").toLowerCase() + " " + u;
  }
  window.addEventListener("error", function (e) {
    if (e.target && e.target !== window) failed.push(what(e.target));
  }, true);
  window.addEventListener("load", function () {
    for (var i = 0; i < document.images.length; i++) {
      var im = document.images[i];
      if (!(im.complete && im.naturalWidth > 0)) failed.push(what(im));
    }
    var loaded = performance.getEntriesByType("resource").map(function (r) { return r.name; });
    // Layout at the window's width: how far each table reaches past its
    // section (a table wider than the page is clipped in its scroll box),
    // and, per figure, each plot frame's numeric tick labels.
    var layout = {width: document.documentElement.clientWidth,
                  scrollWidth: document.documentElement.scrollWidth, tables: [], figures: []};
    var tables = document.querySelectorAll("table");
    for (var i = 0; i < tables.length; i++) {
      var t = tables[i], box = t.closest("section") || document.body;
      var h = t.closest("section"), name = (h && h.id ? h.id : "page") + " table " + (i + 1);
      var prev = t.closest(".scroll") || t;
      while (prev && !/^H[1-4]$/.test(prev.tagName)) prev = prev.previousElementSibling;
      if (prev) name += " (" + prev.textContent.trim() + ")";
      layout.tables.push({name: name,
        over: Math.round(t.getBoundingClientRect().right - box.getBoundingClientRect().right)});
    }
    var num = /^[-\u2212]?\d+(\.\d+)?$/;
    var figs = document.querySelectorAll("figure");
    for (var f = 0; f < figs.length; f++) {
      var svg = figs[f].querySelector("svg"), frames = [];
      if (svg) {
        var texts = Array.prototype.map.call(svg.querySelectorAll("text"), function (e) {
          return {s: e.textContent.trim(), r: e.getBoundingClientRect()};
        });
        var rects = svg.querySelectorAll("rect");
        for (var k = 0; k < rects.length; k++) {
          var re = rects[k];
          if (re.getAttribute("fill") !== "none" || (re.getAttribute("stroke") || "none") === "none") continue;
          var b = re.getBoundingClientRect(), xs = [], ys = [], overlap = false;
          texts.forEach(function (x) {
            if (!num.test(x.s)) return;
            var cx = (x.r.left + x.r.right) / 2, cy = (x.r.top + x.r.bottom) / 2;
            if (cx >= b.left - 2 && cx <= b.right + 2 && x.r.top >= b.bottom - 1 && x.r.top <= b.bottom + 24) xs.push(x);
            if (cy >= b.top - 2 && cy <= b.bottom + 2 && x.r.right <= b.left + 1 && x.r.right >= b.left - 48) ys.push(x);
          });
          [xs, ys].forEach(function (v) {
            for (var a = 0; a < v.length; a++) for (var c = a + 1; c < v.length; c++) {
              var p = v[a].r, q = v[c].r;
              if (p.left < q.right && q.left < p.right && p.top < q.bottom && q.top < p.bottom) overlap = true;
            }
          });
          var uniq = function (v) { return v.map(function (x) { return x.s; }).filter(function (s, j, a) { return a.indexOf(s) === j; }).length; };
          frames.push({x: uniq(xs), y: uniq(ys), overlap: overlap});
        }
      }
      layout.figures.push({id: figs[f].id, frames: frames});
    }
    var pre = document.createElement("pre");
    pre.id = "mapgauge-load-check";
    pre.textContent = JSON.stringify({failed: failed, loaded: loaded, layout: layout});
    document.body.appendChild(pre);
  });
})();</script>"""
at = src.find("<head>")
at = at + len("<head>") if at >= 0 else 0
open(sys.argv[2], "w", encoding="utf-8").write(src[:at] + js + src[at:])
PY

# No network here: without these flags Chromium stalls on connection attempts.
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run
    --disable-background-networking --disable-component-update --disable-sync
    --disable-default-apps --disable-extensions --hide-scrollbars
    --enable-logging=stderr --v=0)

# A tall window so the screenshot shows the summary, the overview and the first targets.
timeout 90 /usr/bin/chromium "${flags[@]}" --user-data-dir="$work/profile-shot" \
    --window-size=1100,2400 --screenshot="$shot" "file://$report" \
    >"$work/shot.out" 2>"$work/shot.err" || {
    cat "$work/shot.err" >&2
    echo "browser check: chromium failed to take a screenshot" >&2
    exit 1
}
# The probe's copy; the virtual-time budget lets every load finish (or fail)
# before the DOM is written.
# At 1280 px, the width the report must fit without a table running off it.
timeout 90 /usr/bin/chromium "${flags[@]}" --user-data-dir="$work/profile-dom" \
    --window-size=1280,2400 --virtual-time-budget=10000 --dump-dom "file://$probe" \
    >"$work/dom.html" 2>"$work/dom.err" || {
    cat "$work/dom.err" >&2
    echo "browser check: chromium failed to dump the DOM" >&2
    exit 1
}

ROUTE="$route" python3 - "$report" "$result" "$shot" "$work/dom.html" "$work/shot.err" "$work/dom.err" <<'EOF'
import csv, html, json, re, struct, sys, zlib

report, result, shot, dom_path, *logs = sys.argv[1:]
route = __import__("os").environ.get("ROUTE", "")
fail = []

# 1. Console messages. Headless Chromium logs every console message (errors,
# uncaught exceptions, failed loads) as an INFO:CONSOLE line without its level.
# The report has no script, so any console message at all is a failure.
for log in logs:
    for line in open(log, errors="replace"):
        if ":CONSOLE" in line or "Uncaught" in line or "net::ERR_" in line:
            fail.append("console: " + line.strip())

# 2. Every figure is in the rendered DOM, as many as result.json implies: the
# overview, the relative errors, the errors' CDF, the errors along the route
# (a run given --trajectory: asked for by `route`) and one per target, found
# or not (figures() in src/report/plots/mod.rs), each a <figure> holding one
# <svg>.
src = open(report, encoding="utf-8").read()
dom = open(dom_path, encoding="utf-8", errors="replace").read()
# A failed run's page: one figure per surveyed place, as failed.csv lists.
failure = result.endswith("failed.csv")
try:
    if failure:
        n_targets = sum(1 for _ in csv.reader(open(result, encoding="utf-8"))) - 1
    else:
        n_targets = len(json.load(open(result, encoding="utf-8"))["targets"])
except Exception as e:  # unreadable is a failed check, not a pass
    n_targets = None
    fail.append(f"{result} unreadable: {e}")
n_svg = len(re.findall(r"<svg[\s>]", dom))
figs = re.findall(r'<figure id="(fig-[^"]*)"[^>]*>(.*?)</figure>', dom, re.S)
ids = [i for i, _ in figs]
if n_targets is not None:
    want = n_targets + (0 if failure else 3 + (route == "route"))
    if n_svg != want:
        fail.append(f"{n_svg} <svg> elements in the DOM, result.json implies {want}"
                    f" (overview, relative, error CDF{', route' if route else ''}, {n_targets} targets)")
    n_fig = sum(i.startswith("fig-target-") for i in ids)
    if n_fig != n_targets:
        fail.append(f"{n_fig} target figures, result.json has {n_targets} targets")
    m = re.search(r'<meta name="mapgauge-figures" content="(\d+)">', src)
    if m and int(m.group(1)) != want:
        fail.append(f"the page declares {m.group(1)} figures, result.json implies {want}")
needed = ("fig-overview", "fig-relative", "fig-error-cdf") + (("fig-error-route",) if route == "route" else ())
for need in () if failure else needed:
    if ids.count(need) != 1:
        fail.append(f"{ids.count(need)} figures {need}, want 1")
for i, body in figs:
    if len(re.findall(r"<svg[\s>]", body)) != 1:
        fail.append(f"figure {i} holds no drawing")
if "Map accuracy report" not in dom:
    fail.append("the DOM lacks the report heading")

# 3. Resources: none may fail to load (the probe's record), and none may come
# from outside the page: a reference that loads here (a file beside the
# report) breaks when the report is mailed or archived. The page's own source
# is read too, for what a browser would fetch lazily or not at all.
m = re.search(r'<pre id="mapgauge-load-check">(.*?)</pre>', dom, re.S)
if not m:
    fail.append("the load probe did not report (the page never finished loading?)")
else:
    probe = json.loads(html.unescape(m.group(1)))
    for f in sorted(set(probe["failed"])):
        fail.append("resource failed to load: " + f)
    for u in sorted(set(probe["loaded"])):
        if not u.startswith("data:"):
            fail.append("resource fetched from outside the page: " + u)
    # 5. At 1280 px no table runs off the page (hidden columns, a clipped
    # hash), and every plot frame has a scale: at least two distinct numeric
    # tick labels on each axis, none overlapping another.
    lay = probe.get("layout") or {}
    if lay.get("width") != 1280:
        fail.append(f"the page was laid out {lay.get('width')} px wide, not 1280")
    if lay.get("scrollWidth", 0) > lay.get("width", 0) + 1:
        fail.append(f"the page is {lay['scrollWidth']} px wide at {lay.get('width')} px")
    for t in lay.get("tables", []):
        if t["over"] > 1:
            fail.append(f"{t['name']} overflows its section by {t['over']} px at 1280 px")
    for fig in lay.get("figures", []):
        if not fig["frames"]:
            fail.append(f"figure {fig['id']} has no plot frame with axes")
        for k, fr in enumerate(fig["frames"]):
            if fr["x"] < 2 or fr["y"] < 2:
                fail.append(f"figure {fig['id']} panel {k + 1}: {fr['x']} labelled x ticks, "
                            f"{fr['y']} labelled y ticks (want 2 or more each)")
            if fr["overlap"]:
                fail.append(f"figure {fig['id']} panel {k + 1}: tick labels overlap")
attr = r"""<(?!a[\s>])([a-zA-Z][\w:-]*)[^>]*?\s(?:src|href|xlink:href|srcset|data|poster|background)\s*=\s*["']?([^"'\s>]+)"""
refs = re.findall(attr, src)
refs += [("css", u) for u in re.findall(r"""url\(\s*["']?([^"')]+)""", src)]
refs += [("css", u) for u in re.findall(r"""@import\s+(?:url\()?["']?([^"')\s;]+)""", src)]
for tag, u in refs:
    if not (u.startswith("data:") or u.startswith("#")):
        fail.append(f"resource outside the page: <{tag}> {u}")

# 4. Not blank: decode the PNG (8-bit RGB/RGBA, no interlace) and count colours.
def png_pixels(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, w = 8, b"", 0
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and ctype in (2, 6) and interlace == 0, "unexpected PNG type"
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    stride = w * bpp
    prev = bytearray(stride)
    rows = []
    i = 0
    for _ in range(h):
        f = raw[i]
        line = bytearray(raw[i + 1:i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[x] = (line[x] + pr) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, bpp, rows

try:
    w, h, bpp, rows = png_pixels(shot)
    counts = {}
    for r in rows[::4]:
        for x in range(0, len(r), bpp * 4):
            px = r[x:x + 3]
            counts[px] = counts.get(px, 0) + 1
    total = sum(counts.values())
    top = max(counts.values())
    print(f"browser check: screenshot {w}x{h}, {len(counts)} colours, most common {top / total:.1%}")
    if top / total > 0.97 or len(counts) < 16:
        fail.append(f"blank page: one colour covers {top / total:.1%} of the screenshot")
except Exception as e:  # a PNG we cannot read is a failed check, not a pass
    fail.append(f"screenshot unreadable: {e}")

if fail:
    for f in fail:
        print("browser check FAILED:", f, file=sys.stderr)
    sys.exit(1)
print(f"browser check: ok ({n_svg} figures, as {result.rsplit('/', 1)[-1]} implies, each panel with labelled ticks; "
      "no table wider than the page at 1280 px; no console message; no failed or outside resource)")
EOF
echo "browser check: screenshot at $shot"
