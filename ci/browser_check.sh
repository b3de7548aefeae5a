#!/usr/bin/env bash
# Renders a report.html in headless Chromium and fails on a console error, a
# blank page or a missing figure. Usage: ci/browser_check.sh REPORT.html [SCREENSHOT.png]
# Installs Debian's chromium when it is missing (CI runs as root).
set -euo pipefail
report=$(realpath "$1")
shot=${2:-$(dirname "$report")/report.png}
shot=$(realpath -m "$shot")

if [ ! -x /usr/bin/chromium ]; then
    echo "browser check: installing chromium" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq chromium >/dev/null
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
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
timeout 90 /usr/bin/chromium "${flags[@]}" --user-data-dir="$work/profile-dom" \
    --dump-dom "file://$report" >"$work/dom.html" 2>"$work/dom.err" || {
    cat "$work/dom.err" >&2
    echo "browser check: chromium failed to dump the DOM" >&2
    exit 1
}

python3 - "$report" "$shot" "$work/dom.html" "$work/shot.err" "$work/dom.err" <<'EOF'
import re, struct, sys, zlib

report, shot, dom_path, *logs = sys.argv[1:]
fail = []

# 1. Console errors. Headless Chromium logs every console message (errors,
# uncaught exceptions, failed loads) as an INFO:CONSOLE line without its level.
# The report has no script, so any console message at all is a failure.
for log in logs:
    for line in open(log, errors="replace"):
        if ":CONSOLE" in line or "Uncaught" in line or "net::ERR_" in line:
            fail.append("console: " + line.strip())

# 2. Every figure is in the rendered DOM: as many <svg> as the page says it has.
src = open(report, encoding="utf-8").read()
m = re.search(r'<meta name="mapgauge-figures" content="(\d+)">', src)
if not m:
    fail.append("report.html has no mapgauge-figures count")
dom = open(dom_path, encoding="utf-8", errors="replace").read()
n_svg = len(re.findall(r"<svg[\s>]", dom))
if m and n_svg != int(m.group(1)):
    fail.append(f"{n_svg} <svg> elements in the DOM, the report has {m.group(1)}")
if "Map accuracy report" not in dom:
    fail.append("the DOM lacks the report heading")

# 3. Not blank: decode the PNG (8-bit RGB/RGBA, no interlace) and count colours.
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
print(f"browser check: ok ({n_svg} figures, no console errors)")
EOF
echo "browser check: screenshot at $shot"
