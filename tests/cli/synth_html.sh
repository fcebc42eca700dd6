#!/usr/bin/env bash
# REPORT.html renders in headless Chromium (Debian `chromium`, scripts/synth-setup):
# the DOM has the filmstrips (query, ranked partial motions, synthesised
# motion from the front and the side), the top view, the contact timeline,
# the ranking table and the energy curve, and the screenshot is not
# blank (many non-white pixels, several colours). The page must load with no
# network (it has no external references; checked too).
#   bash tests/cli/synth_html.sh BUILD_DIR DATA_DIR
set -euo pipefail
build="${1:?usage: synth_html.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: synth_html.sh BUILD_DIR DATA_DIR}"
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
synth="$build/synth/mocap-synth"
indexer="$build/indexer/mocap-index"
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
skip() { missing_tool scripts/synth-setup "$@"; }
[ -x "$synth" ] || { echo "FAIL: $synth not built" >&2; exit 1; }
[ -d "$data/bandai-namco-1/data" ] || { echo "SKIP: no data at $data"; exit 77; }
chromium="${CHROMIUM:-$(command -v chromium || command -v chromium-browser || true)}"
[ -n "$chromium" ] || skip "chromium not found"
[ -x /usr/bin/python3 ] || skip "/usr/bin/python3 not found"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$indexer" build --out "$tmp/index.h5" "$data/bandai-namco-1" "$data/cmu" >/dev/null 2>&1
python3 "$here/../synth/synth_fixture.py" --index-data "$data" --out "$tmp" >/dev/null
"$synth" --index "$tmp/index.h5" --query "$tmp/query.json" --results "$tmp/results.jsonl" \
  --out "$tmp/m.bvh" --html "$tmp/report.html" >/dev/null
if grep -Eq '(src|href)="(https?:)?//' "$tmp/report.html"; then echo "FAIL: external reference in the page" >&2; exit 1; fi
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking
       --disable-component-update --disable-sync --user-data-dir="$tmp/profile" --window-size=1400,2000)
timeout 120 "$chromium" "${flags[@]}" --dump-dom "file://$tmp/report.html" >"$tmp/dom.html" 2>/dev/null
for fig in filmstrip-query filmstrip-pair1-rank1 filmstrip-pair2-rank1 filmstrip-motion filmstrip-motion-side \
    top-view contacts ranking energy transitions; do
  grep -q "data-figure=\"$fig\"" "$tmp/dom.html" || { echo "FAIL: figure $fig missing from the rendered DOM" >&2; exit 1; }
done
n_lines=$(grep -o '<line ' "$tmp/dom.html" | wc -l)
[ "$n_lines" -gt 100 ] || { echo "FAIL: only $n_lines stick-figure bones rendered" >&2; exit 1; }
timeout 120 "$chromium" "${flags[@]}" --screenshot="$tmp/shot.png" "file://$tmp/report.html" >/dev/null 2>&1
[ -s "$tmp/shot.png" ] || { echo "FAIL: no screenshot" >&2; exit 1; }
/usr/bin/python3 - "$tmp/shot.png" <<'PY'
import struct, sys, zlib
data = open(sys.argv[1], "rb").read()
assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
pos, idat, w = 8, b"", 0
while pos < len(data):
    n, kind = struct.unpack(">I4s", data[pos:pos + 8])
    body = data[pos + 8:pos + 8 + n]
    if kind == b"IHDR":
        w, h, depth, ctype = struct.unpack(">IIBB", body[:10])
        assert depth == 8 and ctype in (2, 6), (depth, ctype)
        bpp = 3 if ctype == 2 else 4
    elif kind == b"IDAT":
        idat += body
    pos += 12 + n
raw = zlib.decompress(idat)
stride = w * bpp
prev = bytearray(stride)
colours, nonwhite = set(), 0
for y in range(h):
    f = raw[y * (stride + 1)]
    line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = line[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        if f == 1: line[i] = (line[i] + a) & 255
        elif f == 2: line[i] = (line[i] + b) & 255
        elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
        elif f == 4:
            p = a + b - c; pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
            line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
    prev = line
    if y % 2 == 0:
        for x in range(0, w, 2):
            px = tuple(line[x * bpp:x * bpp + 3])
            colours.add(px)
            if px != (255, 255, 255): nonwhite += 1
frac = nonwhite / ((w // 2) * (h // 2))
print(f"screenshot {w}x{h}: {len(colours)} colours, {100 * frac:.1f}% non-white")
assert len(colours) >= 8, "screenshot looks blank (too few colours)"
assert frac > 0.05, "screenshot looks blank (almost all white)"
PY
echo "ok: REPORT.html renders with its figures"
