#!/usr/bin/env bash
# mocap-index inspect: the JSON contract on real files, and errors for bad arguments.
# Usage: inspect.sh BUILD_DIR DATA_DIR   (exit 77 = skipped: no data)
set -euo pipefail
bin="$1/indexer/mocap-index"
data="$2"
[ -d "$data/bandai-namco-1/data" ] || { echo "no data at $data"; exit 77; }
bn="$data/bandai-namco-1/data/dataset-1_walk_normal_001.bvh"
cmu="$data/cmu/131_01.bvh"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$bin" inspect "$bn" --frame 10 --json > "$tmp/bn.json"
"$bin" inspect "$cmu" --frame 0 --unit cmu --json > "$tmp/cmu.json"
"$bin" inspect "$bn" --frame 10 --unit cm --character "$(dirname "$0")/../../docs/examples/character-heavy-arms.json" --json > "$tmp/heavy.json"
python3 - "$tmp" <<'PY'
import json, sys, os
tmp = sys.argv[1]
for name in ("bn", "cmu", "heavy"):
    d = json.load(open(os.path.join(tmp, name + ".json")))
    for key in ("file", "frames", "frame_time_s", "unit_scale_m", "total_mass_kg", "joints", "segments"):
        assert key in d, (name, key)
    for i, j in enumerate(d["joints"]):
        assert set(("name", "parent", "position_m")) <= set(j), j
        assert -1 <= j["parent"] < i, j
        assert len(j["position_m"]) == 3
    for s in d["segments"]:
        assert set(("joint", "class", "mass_kg", "com_m")) <= set(s), s
        assert s["mass_kg"] > 0
    ys = [j["position_m"][1] for j in d["joints"]]
    assert 1.2 < max(ys) - min(ys) < 2.1, (name, max(ys) - min(ys))
    assert abs(sum(s["mass_kg"] for s in d["segments"]) - d["total_mass_kg"]) < 1e-6
bn = json.load(open(os.path.join(tmp, "bn.json")))
assert bn["unit_scale_m"] == 0.01 and bn["frames"] > 10 and abs(bn["frame_time_s"] - 1 / 30) < 1e-6
assert json.load(open(os.path.join(tmp, "cmu.json")))["unit_scale_m"] == 0.056444
heavy = json.load(open(os.path.join(tmp, "heavy.json")))
arm = lambda d: sum(s["mass_kg"] for s in d["segments"] if s["class"] == "upper_arm")
assert arm(heavy) > arm(bn), (arm(heavy), arm(bn))
print("inspect JSON contract ok")
PY

# Errors: non-zero exit and a message naming the problem.
expect_fail() {
  local what="$1"; shift
  if "$bin" "$@" > "$tmp/out" 2> "$tmp/err"; then echo "expected failure: $what"; exit 1; fi
  grep -q -- "$what" "$tmp/err" || { echo "message lacks '$what':"; cat "$tmp/err"; exit 1; }
}
expect_fail "out of range" inspect "$bn" --frame 999999 --json
expect_fail "no-such.bvh" inspect "$tmp/no-such.bvh" --frame 0 --json
expect_fail "unit" inspect "$bn" --frame 0 --unit furlong --json
expect_fail "expected y, z or auto" inspect "$bn" --frame 0 --up x --json
printf 'HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 2 Xposition Wrotation\n}\n' > "$tmp/bad.bvh"
expect_fail "bad.bvh:5" inspect "$tmp/bad.bvh" --frame 0 --json
echo "inspect errors ok"

# --up and dm: a 17 dm figure standing along +Z (hand-written) is detected as
# Z up and dm and rotated to Y up, (x, y, z) -> (x, z, -y); declared --up y
# keeps the file's axes.
printf '%s\n' HIERARCHY 'ROOT Hips' '{' ' OFFSET 0 0 9' \
  ' CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation' \
  ' JOINT Head' ' {' '  OFFSET 0 1 7' '  CHANNELS 3 Zrotation Yrotation Xrotation' \
  '  End Site Head_end' '  {' '   OFFSET 0 0 1' '  }' ' }' ' JOINT Foot' ' {' '  OFFSET 0 0 -9' \
  '  CHANNELS 3 Zrotation Yrotation Xrotation' '  End Site' '  {' '   OFFSET 0 0 0' '  }' ' }' '}' \
  MOTION 'Frames: 1' 'Frame Time: 0.1' '1 2 9 0 0 0 0 0 0 0 0 0' > "$tmp/zup.bvh"
"$bin" inspect "$tmp/zup.bvh" --frame 0 --json > "$tmp/zup.json"
"$bin" inspect "$tmp/zup.bvh" --frame 0 --up y --unit dm --json > "$tmp/zup-y.json"
python3 - "$tmp" <<'PY'
import json, os, sys
tmp = sys.argv[1]
auto = json.load(open(os.path.join(tmp, "zup.json")))
kept = json.load(open(os.path.join(tmp, "zup-y.json")))
assert auto["up"] == "z" and auto["unit"] == "dm", (auto["up"], auto["unit"])
assert kept["up"] == "y" and kept["unit"] == "dm"
for a, k in zip(auto["joints"], kept["joints"]):
    x, y, z = k["position_m"]
    assert max(abs(p - q) for p, q in zip(a["position_m"], (x, z, -y))) < 1e-12, (a, k)
head = {j["name"]: j["position_m"] for j in auto["joints"]}["Head"]
assert abs(head[0] - 0.1) < 1e-12 and abs(head[1] - 1.6) < 1e-12 and abs(head[2] + 0.3) < 1e-12, head
print("inspect --up ok")
PY
