#!/usr/bin/env bash
# mocap-search energy: the JSON contract on real files, and errors for bad arguments.
# Usage: energy_cli.sh BUILD_DIR DATA_DIR   (exit 77 = skipped: no data or no binary)
set -euo pipefail
bin="$1/search/mocap-search"
data="$2"
[ -x "$bin" ] || { echo "no $bin"; exit 77; }
[ -d "$data/bandai-namco-1/data" ] || { echo "no data at $data"; exit 77; }
walk="$data/bandai-namco-1/data/dataset-1_walk_normal_001.bvh"
cmu="$data/cmu/131_01.bvh"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

"$bin" energy --from "$walk:10" --to "$walk:25" --json > "$tmp/a.json"
"$bin" energy --from "$walk:10" --to "$walk:10" --json > "$tmp/same.json"
"$bin" energy --from "$walk:10" --to "$walk:25" --transition-time 1.0 --unit cm --json > "$tmp/slow.json"
"$bin" energy --from "$cmu:100" --to "$cmu:400" --unit cmu --json > "$tmp/cmu.json"
"$bin" energy --from "$walk:10" --to "$walk:25" > "$tmp/a.txt"
grep -q "Hips" "$tmp/a.txt"
python3 - "$tmp" <<'PY'
import json, os, sys
tmp = sys.argv[1]
def load(n): return json.load(open(os.path.join(tmp, n + ".json")))
for name in ("a", "same", "slow", "cmu"):
    d = load(name)
    assert set(("h_J", "g_J", "terms")) <= set(d), (name, d.keys())
    assert d["g_J"] >= d["h_J"] >= 0, (name, d["h_J"], d["g_J"])
    for t in d["terms"]:
        assert set(("name", "kind", "h_J", "g_J")) <= set(t), t
        assert t["kind"] in ("segment", "joint"), t
        assert t["g_J"] >= t["h_J"] >= 0, t
    assert abs(sum(t["h_J"] for t in d["terms"]) - d["h_J"]) <= 1e-9 * max(1, d["h_J"])
    assert abs(sum(t["g_J"] for t in d["terms"]) - d["g_J"]) <= 1e-9 * max(1, d["g_J"])
assert load("same")["h_J"] == 0
assert 0 < load("slow")["h_J"] < load("a")["h_J"]
print("energy JSON contract ok")
PY

# Bad arguments: clear message on stderr, non-zero exit.
expect_fail() {
  if "$bin" "$@" > "$tmp/out" 2> "$tmp/err"; then echo "expected failure: $*"; exit 1; fi
  [ -s "$tmp/err" ] || { echo "no message on stderr for: $*"; exit 1; }
}
expect_fail energy --from "$walk:10" --to "$walk:100000" --json
expect_fail energy --from "$walk" --to "$walk:1" --json
# Another rig is compared on the shared segments (docs/cli.md); one whose
# skeleton has no recognised pelvis cannot be retargeted.
"$bin" energy --from "$walk:1" --to "$cmu:1" --json | grep -q '"cross_rig":true'
printf 'HIERARCHY\nROOT a\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT b\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n0 90 0 0 0 0 0 0 0\n0 90 0 0 0 0 0 0 0\n' > "$tmp/odd.bvh"
expect_fail energy --from "$walk:1" --to "$tmp/odd.bvh:1" --json
grep -q "pelvis" "$tmp/err"
expect_fail energy --from /nonexistent.bvh:0 --to "$walk:1" --json
expect_fail energy --from "$walk:1" --to "$walk:2" --transition-time 0 --json
for t in 1e-300 0.0009 61 inf nan; do
  expect_fail energy --from "$walk:1" --to "$walk:2" --transition-time "$t" --json
  grep -q -- "--transition-time: must be 0.001 to 60 seconds" "$tmp/err" || { cat "$tmp/err"; exit 1; }
done
expect_fail energy --from "$walk:1" --to "$walk:2" --unit furlong --json
expect_fail energy --from "$walk:1"
expect_fail

# --motion: a whole motion summed over its steps; W beside g.
"$bin" energy --motion "$walk" --frames 40-71 --json > "$tmp/m.json"
"$bin" energy --motion "$walk" --frames 40-71 > "$tmp/m.txt"
grep -q "^W = " "$tmp/m.txt"
grep -q "frames without contact" "$tmp/m.txt"
python3 - "$tmp/m.json" "$tmp/a.json" <<'PY'
import json, sys
m, a = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert m["motion"]["steps"] == 31 and len(m["step_g_J"]) == 31 == len(m["step_w_J"]), m["motion"]
assert abs(sum(m["step_g_J"]) - m["g_J"]) <= 1e-9 * m["g_J"]
assert abs(sum(m["step_w_J"]) - m["w_J"]) <= 1e-9 * m["w_J"]
assert abs(sum(m["parts"].values()) - m["g_J"]) <= 1e-9 * m["g_J"], m["parts"]
assert abs(sum(m["w_parts"].values()) - m["w_J"]) <= 1e-9 * m["w_J"], m["w_parts"]
assert 0 <= m["no_contact_ratio"] <= 1 and m["peak_angular_speed_radps"] > 0 and m["peak_joint"]
assert 0 <= m["skating_ratio"] <= 1 and m["skating_steps"] <= 31
for d in (m, a):
    assert d["w_J"] >= 0 and set(d["w_parts"]) == {"joint_J", "ground_J", "residual_work_J", "unsupported_J"}
print("energy --motion JSON ok")
PY
expect_fail energy --motion "$walk" --frames 5-5
grep -q "S < E" "$tmp/err"
expect_fail energy --motion "$walk" --frames 0-100000
expect_fail energy --motion "$walk" --frames 7
expect_fail energy --motion "$walk" --from "$walk:1" --to "$walk:2"
expect_fail energy --motion "$walk" --transition-time 0.1
expect_fail energy --from "$walk:1" --to "$walk:2" --frames 1-3
expect_fail energy --motion /nonexistent.bvh
expect_fail energy --motion "$walk" --unsupported-speed -1
grep -q "unsupported-speed" "$tmp/err"
# The price of unsupported force scales only W's unsupported part.
"$bin" energy --motion "$walk" --frames 40-71 --unsupported-speed 10 --json > "$tmp/m10.json"
python3 - "$tmp/m.json" "$tmp/m10.json" <<'PY'
import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert a["g_J"] == b["g_J"]
assert abs(b["w_parts"]["unsupported_J"] - 2 * a["w_parts"]["unsupported_J"]) <= 1e-9 * (1 + b["w_J"])
assert b["w_parts"]["joint_J"] == a["w_parts"]["joint_J"]
PY
echo "energy CLI ok"
