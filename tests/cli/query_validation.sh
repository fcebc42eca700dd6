#!/usr/bin/env bash
# Query validation end to end (docs/queries.md "Validation") on set-1 bows and
# walks with CMU subject 131 (a foreign skeleton): a misspelt filter label is
# an error listing the labels the index (or collection) holds, exit 1, the
# batch going on; `only` names are read on the query file's own skeleton; an
# unknown joint is reported before its missing order; mocap-synth --query
# takes a batch file with --id, and searches with the same checks.
#   bash tests/cli/query_validation.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup query_validation "$@"
[ -d "$data/cmu" ] || { echo "SKIP: no CMU files at $data/cmu"; exit 77; }
set1="$data/bandai-namco-1/data"
# The sidecars' label numbers are lines of ../cfg/*_label.txt.
mkdir -p "$tmp/in/data" "$tmp/in/cmu"
ln -s "$data/bandai-namco-1/cfg" "$tmp/in/cfg"
for f in "$set1"/dataset-1_bow_* "$set1"/dataset-1_walk_*; do ln -s "$f" "$tmp/in/data/"; done
for f in "$data"/cmu/131_0*.bvh; do ln -s "$f" "$tmp/in/cmu/"; done
"$indexer" build -q --out "$tmp/i.h5" "$tmp/in" >/dev/null
"$indexer" build -q --shards 2 --out "$tmp/c.json" "$tmp/in" >/dev/null
W="$set1/dataset-1_walk_normal_001.bvh"
C="$data/cmu/131_01.bvh"
# The styles and contents the index holds, from the file names
# (dataset-1_{content}_{style}_{take}.bvh), sorted.
styles=$(cd "$tmp/in/data" && ls dataset-1_*.bvh | cut -d_ -f3 | sort -u | paste -sd, | sed 's/,/, /g')
R='[{"root_position": [0, null, 0]}, {"root_position": [0, null, 1.5]}]'
cat >"$tmp/q.jsonl" <<Q
{"id": "happy-walks", "frames": $R, "filter": {"content": "walk", "style": ["happy"]}, "top": 3}
{"id": "typo-style", "frames": $R, "filter": {"style": ["happpy"]}}
{"id": "typo-content", "frames": $R, "filter": {"content": ["walk", "wlak"]}}
{"id": "only-cmu", "frames": [{"bvh": "$C", "frame": 200, "only": ["root_position_xz", "LeftHipp"]}, {"root_position": [0, null, 1]}]}
{"id": "only-cmu-ok", "frames": [{"bvh": "$C", "frame": 200, "only": ["root_position_xz", "LeftHip", "LeftKnee"]}, {"root_position": [0, null, 1]}], "top": 2}
{"id": "only-bn", "frames": [{"bvh": "$W", "frame": 20, "only": ["LThumb"]}, {"root_position": [0, null, 1]}]}
{"id": "misspelt-joint", "frames": [{"joints": {"RightArmm": {"euler_deg": [0, 40, 0]}}}, {"root_position": [0, null, 0]}]}
{"id": "known-joint", "frames": [{"joints": {"RightArm": {"euler_deg": [0, 40, 0]}}}, {"root_position": [0, null, 0]}]}
Q
status=0
"$search" -q --index "$tmp/i.h5" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" || status=$?
[ "$status" -eq 1 ] || fail "a batch with failing queries: exit $status (expected 1)"
python3 - "$tmp/r.jsonl" "$styles" "$C" <<'PY' || fail "mocap-search messages"
import json, sys
lines = {o["id"]: o for o in map(json.loads, open(sys.argv[1]))}
styles, cmu = sys.argv[2], sys.argv[3]
assert len(lines) == 8, list(lines)
ok = lines["happy-walks"]["pairs"][0]["results"]
assert ok and all(r["labels"] == {"content": "walk", "style": "happy"} for r in ok), ok
assert "happy" in styles.split(", ") and "angry" in styles.split(", "), styles
e = lines["typo-style"]["error"]
assert e == 'query typo-style: filter.style: unknown value "happpy"; the index has: ' + styles, e
e = lines["typo-content"]["error"]
assert e == 'query typo-content: filter.content: unknown value "wlak"; the index has: bow, walk', e
# `only` on a CMU frame: the CMU skeleton's joints and the root fields, not
# the Bandai Namco (index) joints.
e = lines["only-cmu"]["error"]
assert e.startswith('query only-cmu: frames[0].only[1]: unknown name "LeftHipp"'), e
assert cmu in e, e
assert "root_position, root_position_xz, root_heading, Hips, LHipJoint, LeftHip, LeftKnee" in e, e
for bn in ("joint_Root", "UpperLeg_L", "Shoulder_L"):
    assert bn not in e, (bn, e)
assert lines["only-cmu-ok"]["pairs"][0]["results"], lines["only-cmu-ok"]
# A Bandai Namco frame: its own joints.
e = lines["only-bn"]["error"]
assert 'unknown name "LThumb"' in e and "root_heading, joint_Root, Hips, Spine" in e, e
# The unknown joint before the missing order; a known joint's missing order
# names the query file and line.
e = lines["misspelt-joint"]["error"]
assert 'frames[0].joints.RightArmm: unknown joint "RightArmm"' in e and "order" not in e, e
e = lines["known-joint"]["error"]
assert e.endswith("q.jsonl:8: frames[0].joints.RightArm.order: expected a string such as "
                  '"ZXY" (the order the angles apply in)'), e
PY

# An AMC frame's `only` is read on its ASF skeleton, which the message names.
A="$data/cmu-asf-amc"
if [ -f "$A/charleston1.amc" ]; then
  amc='"amc": "'$A/charleston1.amc'", "asf": "'$A/charleston.asf'", "frame": 300'
  cat >"$tmp/a.jsonl" <<Q
{"id": "amc", "frames": [{$amc, "only": ["root_heading", "Tail"]}, {"root_position": [0, null, 1]}]}
{"id": "amc-ok", "frames": [{$amc, "only": ["root_heading", "lfemur", "LeftUpLeg"]}, {"root_position": [0, null, 1]}], "top": 1}
Q
  status=0
  "$search" -q --index "$tmp/i.h5" --queries "$tmp/a.jsonl" --out "$tmp/ra.jsonl" || status=$?
  [ "$status" -eq 1 ] || fail "AMC only: exit $status (expected 1)"
  python3 - "$tmp/ra.jsonl" "$A/charleston.asf" <<'PY' || fail "AMC only messages"
import json, sys
amc, ok = map(json.loads, open(sys.argv[1]))
e = amc["error"]
assert e.startswith('query amc: frames[0].only[1]: unknown name "Tail": neither a root field '
                    "nor a joint of " + sys.argv[2]), e
assert "root_heading, root, lhipjoint, lfemur, ltibia" in e and "Hips" not in e.split("(valid")[1].split(";")[0], e
assert ok["pairs"][0]["results"], ok
PY
fi

# A collection checks the union of its shards' labels: a content that only
# one shard holds is refused by that shard alone, not by the collection.
echo "{\"id\": \"walks\", \"frames\": $R, \"filter\": {\"content\": \"walk\"}, \"top\": 3}" >"$tmp/w.jsonl"
echo "{\"id\": \"bows\", \"frames\": $R, \"filter\": {\"content\": \"bow\"}, \"top\": 3}" >>"$tmp/w.jsonl"
"$search" -q --index "$tmp/c.json" --queries "$tmp/w.jsonl" --out "$tmp/rc.jsonl" ||
  fail "the collection refused labels its shards hold"
"$search" -q --index "$tmp/i.h5" --queries "$tmp/w.jsonl" --out "$tmp/ri.jsonl"
python3 - "$tmp/rc.jsonl" "$tmp/ri.jsonl" <<'PY' || fail "collection results differ from the index's"
import json, sys
c, i = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
strip = lambda os: [[[(r["clip"], r["start_frame"], r["end_frame"]) for r in p["results"]] for p in o["pairs"]] for o in os]
assert strip(c) == strip(i) and all(strip(c)), (strip(c), strip(i))
PY
refused=0
for shard in "$tmp"/c.shard-*.h5; do
  status=0
  "$search" -q --index "$shard" --queries "$tmp/w.jsonl" --out "$tmp/rs.jsonl" || status=$?
  [ "$status" -eq 0 ] && continue
  grep -q 'filter.content: unknown value' "$tmp/rs.jsonl" || fail "shard $shard: $(cat "$tmp/rs.jsonl")"
  refused=$((refused + 1))
done
[ "$refused" -ge 1 ] || fail "every shard holds both contents: the test proves nothing"
echo "{\"id\": \"typo\", \"frames\": $R, \"filter\": {\"content\": \"wlak\"}}" >"$tmp/t.jsonl"
status=0
"$search" -q --index "$tmp/c.json" --queries "$tmp/t.jsonl" --out "$tmp/rt.jsonl" || status=$?
[ "$status" -eq 1 ] || fail "a misspelt label on a collection: exit $status"
grep -qF 'unknown value \"wlak\"; the collection has: bow, walk"' "$tmp/rt.jsonl" ||
  fail "collection message: $(cat "$tmp/rt.jsonl")"

# mocap-synth --query: a batch file and --id.
expect_synth_error() {  # expect_synth_error TEXT ARGS...
  local text="$1"
  shift
  status=0
  "$synth" "$@" >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 1 ] || fail "mocap-synth $*: exit $status (expected 1): $(cat "$tmp/err.txt")"
  grep -qF -- "$text" "$tmp/err.txt" || fail "mocap-synth $*: expected '$text' in: $(cat "$tmp/err.txt")"
  [ ! -e "$tmp/m.bvh" ] || fail "mocap-synth $*: wrote an output"
}
S='{"bvh": "'$W'", "frame": 10}, {"bvh": "'$W'", "frame": 70}'
cat >"$tmp/s.jsonl" <<Q
{"id": "walk", "frames": [$S], "filter": {"content": "walk"}, "top": 2}

{"id": "bow", "frames": [$R], "filter": {"content": "bow"}}
{"id": "typo", "frames": [$S], "filter": {"style": "nromal"}}
Q
base=(--index "$tmp/i.h5" --out "$tmp/m.bvh" --transition slerp)
expect_synth_error 's.jsonl: holds 3 queries (ids "walk", "bow", "typo"); pick one with --id ID' \
  "${base[@]}" --query "$tmp/s.jsonl"
expect_synth_error 'no query with id "run" (--id); the ids it holds: "walk", "bow", "typo"' \
  "${base[@]}" --query "$tmp/s.jsonl" --id run
expect_synth_error 'query typo: filter.style: unknown value "nromal"; the index has: '"$styles" \
  "${base[@]}" --query "$tmp/s.jsonl" --id typo
expect_synth_error 'query typo: filter.style: unknown value "nromal"; the collection has: '"$styles" \
  --index "$tmp/c.json" --out "$tmp/m.bvh" --query "$tmp/s.jsonl" --id typo
"$synth" "${base[@]}" --query "$tmp/s.jsonl" --id walk --report "$tmp/rep.json" >/dev/null ||
  fail "mocap-synth --id walk failed"
[ -s "$tmp/m.bvh" ] || fail "mocap-synth --id walk wrote no motion"
python3 - "$tmp/rep.json" <<'PY' || fail "mocap-synth --id walk did not run query walk"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["query"]["id"] == "walk", r["query"]
PY
rm "$tmp/m.bvh"
# A single-query file still works with and without its id.
echo "{\"frames\": [$S], \"top\": 2}" >"$tmp/one.json"
"$synth" "${base[@]}" --query "$tmp/one.json" >/dev/null || fail "a single query file"
rm "$tmp/m.bvh"
"$synth" "${base[@]}" --query "$tmp/one.json" --id one >/dev/null || fail "a single query file, --id"
rm "$tmp/m.bvh"
expect_synth_error 'no query with id "walk" (--id); the ids it holds: "one"' \
  "${base[@]}" --query "$tmp/one.json" --id walk
echo "PASS"
