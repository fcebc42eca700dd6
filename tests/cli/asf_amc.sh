#!/usr/bin/env bash
# mocap-index and ASF/AMC takes (docs/asf-amc.md "Pairing in the indexer"):
# - build of the cmu-asf-amc folder: 6 clips (charleston1/2 share
#   charleston.asf by the prefix rule), frame counts from the AMC files, 1/120 s
#   per frame (1/60 with --amc-fps 60), unit "asf" at 0.0254/0.45 m;
# - an AMC without an ASF is skipped with a reason naming the rules;
# - inspect of an AMC frame equals inspect of its converted BVH to 1e-4 m;
# - convert refuses to replace a file that is not BVH;
# - a changed ASF re-parses its takes on an incremental build (a new
#   --amc-fps all takes).
#   bash tests/cli/asf_amc.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup asf_amc "$@"
dir="$data/cmu-asf-amc"
[ -d "$dir" ] || { echo "SKIP: no data at $dir"; exit 77; }
command -v python3 >/dev/null 2>&1 || missing_tool scripts/crosscheck-setup "python3 not found"

# Frames of each take: last frame number - first + 1.
frames_of() {
  local first last
  first="$(grep -E '^[0-9]+[[:space:]]*$' "$1" | head -1 | tr -d '[:space:]')"
  last="$(grep -E '^[0-9]+[[:space:]]*$' "$1" | tail -1 | tr -d '[:space:]')"
  echo $((last - first + 1))
}
total=0
for t in backflip charleston1 charleston2 lambada pirouette zombie; do
  n="$(frames_of "$dir/$t.amc")"
  total=$((total + n))
  "$indexer" inspect "$dir/$t.amc" --frame 0 --json >"$tmp/$t.json"
  python3 - "$tmp/$t.json" "$n" <<'PY' || fail "inspect of $t.amc"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["frames"] == int(sys.argv[2]), (d["frames"], sys.argv[2])
assert abs(d["frame_time_s"] - 1 / 120) < 1e-12, d["frame_time_s"]
assert d["unit"] == "asf" and abs(d["unit_scale_m"] - 0.0254 / 0.45) < 1e-12, d["unit_scale_m"]
PY
done

# 1. The folder: 6 clips, the ASF files are not clips.
"$indexer" build "$dir" --out "$tmp/cmu.h5" --quiet --json >"$tmp/build.json" ||
  fail "build of $dir failed"
"$indexer" info "$tmp/cmu.h5" --json >"$tmp/info.json"
"$indexer" build "$dir" --out "$tmp/cmu60.h5" --amc-fps 60 --quiet >/dev/null ||
  fail "build with --amc-fps 60 failed"
"$indexer" info "$tmp/cmu60.h5" --json >"$tmp/info60.json"
python3 - "$tmp" "$total" <<'PY' || fail "index of the ASF/AMC folder"
import json, sys, os
tmp, total = sys.argv[1], int(sys.argv[2])
b = json.load(open(os.path.join(tmp, "build.json")))
assert b["clips"] == 6 and b["skipped"] == [], b
for name, fps in (("info.json", 120), ("info60.json", 60)):
    d = json.load(open(os.path.join(tmp, name)))
    assert d["clips"] == 6 and d["frames"] == total, (d["clips"], d["frames"], total)
    assert abs(d["duration_s"] - total / fps) < 1e-6, (d["duration_s"], total / fps)
    # charleston1 and charleston2 share one skeleton.
    assert sorted(s["clips"] for s in d["skeletons"]) == [1, 1, 1, 1, 2], d["skeletons"]
print("build ok:", total, "frames")
PY

# 2. An AMC without an ASF (5 ASFs in the folder, no rule names one): skipped, exit 1.
mkdir "$tmp/col"
cp -p "$dir"/* "$tmp/col/"
cp "$dir/lambada.amc" "$tmp/col/orphan.amc"
rc=0
"$indexer" build "$tmp/col" --out "$tmp/col.h5" --quiet --json >"$tmp/orphan.json" || rc=$?
[ "$rc" = 1 ] || fail "build with an unpaired AMC: exit $rc, expected 1"
python3 - "$tmp/orphan.json" <<'PY' || fail "the unpaired AMC's report"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["clips"] == 6, d["clips"]
assert len(d["skipped"]) == 1, d["skipped"]
s = d["skipped"][0]
assert s["path"].endswith("/orphan.amc") and "no ASF skeleton" in s["reason"], s
PY
# ... and with --asf it is indexed like the others.
"$indexer" build "$tmp/col/orphan.amc" --asf "$tmp/col/lambada.asf" --out "$tmp/o.h5" --quiet >/dev/null ||
  fail "build of orphan.amc with --asf"

# 3. inspect of an AMC frame = inspect of the converted BVH (cmu: 0.056444 m,
# within 1e-5 relative of the ASF's 0.0564444 m).
"$indexer" convert "$dir/charleston1.amc" --out "$tmp/c1.bvh" >/dev/null || fail "convert"
head -1 "$tmp/c1.bvh" | grep -q HIERARCHY || fail "convert did not write BVH"
"$indexer" inspect "$dir/charleston1.amc" --frame 200 --json >"$tmp/amc200.json"
"$indexer" inspect "$tmp/c1.bvh" --frame 200 --unit cmu --json >"$tmp/bvh200.json"
python3 - "$tmp/amc200.json" "$tmp/bvh200.json" <<'PY' || fail "AMC vs converted BVH"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert a["frames"] == b["frames"] and abs(a["frame_time_s"] - b["frame_time_s"]) < 1e-9
assert [j["name"] for j in a["joints"]] == [j["name"] for j in b["joints"]]
worst = max(abs(x - y) for ja, jb in zip(a["joints"], b["joints"])
            for x, y in zip(ja["position_m"], jb["position_m"]))
assert worst < 1e-4, worst
print("AMC vs converted BVH: max difference", worst, "m")
PY
# convert of a BVH file round-trips through the same writer.
"$indexer" convert "$tmp/c1.bvh" --out "$tmp/c1b.bvh" >/dev/null || fail "convert of a BVH"
cmp -s "$tmp/c1.bvh" "$tmp/c1b.bvh" || fail "convert of the converted BVH changed it"

# 4. convert refuses to replace a file that is not BVH (exit 2, file kept).
echo "not a motion file" >"$tmp/notes.txt"
rc=0
"$indexer" convert "$dir/zombie.amc" --out "$tmp/notes.txt" 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] || fail "convert over a text file: exit $rc, expected 2"
[ "$(cat "$tmp/notes.txt")" = "not a motion file" ] || fail "convert replaced notes.txt"
grep -q -- "--out" "$tmp/err.txt" || fail "convert's refusal does not name --out: $(cat "$tmp/err.txt")"

# 5. A changed ASF re-parses its takes (charleston1, charleston2), not the others.
rm "$tmp/col/orphan.amc"
"$indexer" build "$tmp/col" --out "$tmp/inc.h5" --quiet >/dev/null || fail "first build"
"$indexer" build "$tmp/col" --out "$tmp/inc.h5" --quiet --json >"$tmp/inc1.json" ||
  fail "second build"
echo "# changed" >>"$tmp/col/charleston.asf"
"$indexer" build "$tmp/col" --out "$tmp/inc.h5" --quiet --json >"$tmp/inc2.json" ||
  fail "build after the ASF changed"
# ... and a new --amc-fps re-parses every take.
"$indexer" build "$tmp/col" --out "$tmp/inc.h5" --amc-fps 60 --quiet --json >"$tmp/inc3.json" ||
  fail "build with a new --amc-fps"
python3 - "$tmp/inc1.json" "$tmp/inc2.json" "$tmp/inc3.json" <<'PY' || fail "incremental build after an ASF or --amc-fps change"
import json, sys
one, two, three = (json.load(open(p)) for p in sys.argv[1:4])
assert one["up_to_date"] and one["reused"] == 6, one
assert not two["up_to_date"] and two["changed"] == 2 and two["reused"] == 4, two
assert three["changed"] == 6 and three["reused"] == 0, three
PY
# 6. Query frames from an AMC take (docs/queries.md): frames 300 and 340 of
# charleston1 find that very partial motion at h = 0 in world placement, and
# the take itself first in the default relative placement; mocap-synth
# reads the same frames.
adir="$(cd "$dir" && pwd)"  # query paths are relative to the query file's folder
amc() { printf '{"amc": "%s/%s.amc", "asf": "%s/%s.asf", "frame": %s}' "$adir" "$1" "$adir" "$2" "$3"; }
printf '{"id": "w", "relative": false, "top": 3, "frames": [%s, %s]}\n{"id": "r", "top": 3, "frames": [%s, %s]}\n' \
  "$(amc charleston1 charleston 300)" "$(amc charleston1 charleston 340)" \
  "$(amc lambada lambada 500)" "$(amc lambada lambada 560)" >"$tmp/amcq.jsonl"
"$search" -q --index "$tmp/cmu.h5" --queries "$tmp/amcq.jsonl" --out "$tmp/amcr.jsonl" 2>"$tmp/err.txt" ||
  fail "search with AMC query frames: $(cat "$tmp/err.txt" "$tmp/amcr.jsonl" 2>/dev/null)"
python3 - "$tmp/amcr.jsonl" <<'PY' || fail "AMC query frames did not find their own take"
import json, sys
w, r = (json.loads(l) for l in open(sys.argv[1]))
best = w["pairs"][0]["results"][0]
assert best["clip"].endswith("charleston1.amc") and best["score_J"] == 0.0, best
assert (best["start_frame"], best["end_frame"]) == (300, 340), best
assert r["pairs"][0]["results"][0]["clip"].endswith("lambada.amc"), r
PY
head -1 "$tmp/amcq.jsonl" >"$tmp/amcq.json"
"$synth" --index "$tmp/cmu.h5" --query "$tmp/amcq.json" --out "$tmp/amc-motion.bvh" >/dev/null 2>&1 ||
  fail "mocap-synth with AMC query frames"
grep -q "^MOTION" "$tmp/amc-motion.bvh" || fail "mocap-synth wrote no motion"
echo "asf_amc ok"
