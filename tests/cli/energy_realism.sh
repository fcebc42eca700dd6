#!/usr/bin/env bash
# scripts/energy-realism at a small size (4 held-out gaps of set 1): it runs,
# its JSON holds every fill's g and W, and the padding does what the method
# says: the capture fill's steps a -> b cost exactly what the take's own
# frames a..b cost in the whole file (mocap-search energy --motion --frames).
# Usage: energy_realism.sh BUILD_DIR DATA_DIR   (exit 77 = skipped: no data or no binary)
set -euo pipefail
build="$1"
data="$2"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="$build/search/mocap-search"
[ -x "$bin" ] || { echo "no $bin"; exit 77; }
[ -d "$data/bandai-namco-1/data" ] || { echo "no data at $data"; exit 77; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

MOCAP_DATA_DIR="$data" "$root/scripts/energy-realism" --build "$build" --clips 4 \
  --json "$tmp/r.json" > "$tmp/r.md" 2> "$tmp/r.err" || { cat "$tmp/r.err"; exit 1; }
grep -q "capture below in W" "$tmp/r.md"
/usr/bin/python3 - "$tmp/r.json" "$bin" "$data/bandai-namco-1/data" <<'PY'
import json, os, subprocess, sys
r, search, data = json.load(open(sys.argv[1])), sys.argv[2], sys.argv[3]
gaps = r["sets"]["1"]["gaps"]
assert len(gaps) >= 3, len(gaps)
for g in gaps:
    for kind in ("capture", "interpolation", "zero-velocity", "inertialization"):
        m = g[kind]
        assert m["g_J"] >= m["h_J"] >= 0 and m["w_J"] >= 0, (g["clip"], kind, m)
    own = json.loads(subprocess.run(
        [search, "energy", "--motion", os.path.join(data, g["clip"]), "--frames",
         f'{g["a"]}-{g["b"]}', "--json"], check=True, capture_output=True, text=True).stdout)
    for e in ("g_J", "w_J"):
        assert abs(own[e] - g["capture"][e]) <= 1e-6 * own[e], (g["clip"], e, own[e], g["capture"][e])
s = r["sets"]["1"]["summary"]["all"]
assert s["gaps"] == len(gaps) and "capture_below_w" in s["interpolation"], s
print(f"energy-realism ok: {len(gaps)} gaps; capture fill = the take's own frames in g and W")
PY
