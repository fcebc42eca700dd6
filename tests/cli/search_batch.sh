#!/usr/bin/env bash
# mocap-search contract end to end on a set-1 + CMU index: output lines,
# fields, error lines, exit statuses, threads 1 == 2, --query.
set -euo pipefail
BUILD=$1; DATA=$2
SEARCH=$BUILD/search/mocap-search; INDEXER=$BUILD/indexer/mocap-index
[ -d "$DATA/bandai-namco-1/data" ] || { echo "no data at $DATA"; exit 77; }
[ -x "$SEARCH" ] && [ -x "$INDEXER" ] || { echo "binaries missing"; exit 77; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
"$INDEXER" build -q --out "$T/i.h5" "$DATA/bandai-namco-1/data" "$DATA/cmu" >/dev/null
W=$DATA/bandai-namco-1/data/dataset-1_walk_normal_001.bvh
cat > "$T/ok.jsonl" <<Q
{"id": "walk", "relative": false, "frames": [{"bvh": "$W", "frame": 10}, {"bvh": "$W", "frame": 40}, {"bvh": "$W", "frame": 70}], "top": 5}
{"id": "arm", "relative": false, "frames": [{"joints": {"RightArm": {"euler_deg": [0, 0, 80], "order": "ZXY"}}}, {"root_position": [0, null, 0]}], "top": 3, "filter": {"content": ["bow", "bye"]}}
Q
# All good: exit 0, one line per query, the contract's fields.
"$SEARCH" --index "$T/i.h5" --queries "$T/ok.jsonl" --out "$T/r1.jsonl" --threads 1 -q
"$SEARCH" --index "$T/i.h5" --queries "$T/ok.jsonl" --out "$T/r2.jsonl" --threads 2 -q
python3 - "$T" <<'PY'
import json, sys
t = sys.argv[1]
one = [json.loads(l) for l in open(t + "/r1.jsonl")]
two = [json.loads(l) for l in open(t + "/r2.jsonl")]
assert [o["id"] for o in one] == ["walk", "arm"], one
for o in one:
    assert set(o) == {"id", "pairs", "stats"}, o.keys()
    assert set(o["stats"]) >= {"clips", "clips_pruned", "frames_evaluated", "frames_pruned", "time_ms"}
    for p in o["pairs"]:
        assert p["to"] == p["from"] + 1
        for r in p["results"]:
            assert set(r) >= {"rank", "clip", "clip_index", "labels", "start_frame", "end_frame",
                              "score_J", "h_in_J", "h_out_J", "path_cost_J"}, r
            assert r["start_frame"] < r["end_frame"]
walk = one[0]
assert len(walk["pairs"]) == 2
top = walk["pairs"][0]["results"][0]
assert top["clip"].endswith("dataset-1_walk_normal_001.bvh") and (top["start_frame"], top["end_frame"]) == (10, 40), top
assert abs(top["score_J"]) < 1e-6
for r in one[1]["pairs"][0]["results"]:
    assert r["labels"]["content"] in ("bow", "bye"), r
strip = lambda os: [[p["results"] for p in o["pairs"]] for o in os]
assert strip(one) == strip(two), "threads 1 != 2"
PY
# Bad lines: error objects on their lines, the batch goes on, exit 1.
cat > "$T/bad.jsonl" <<Q
{"id": "good", "relative": false, "frames": [{"root_position": [0, null, 0]}, {"root_position": [1, null, 0]}]}
{"id": "joint", "frames": [{"joints": {"Tail": {"quat": [1, 0, 0, 0]}}}, {"root_position": [0, null, 0]}]}
{"id": "file", "frames": [{"bvh": "missing.bvh", "frame": 0}, {"root_position": [0, null, 0]}]}
this is not json
{"id": "character", "character": "no-such-character.json", "frames": [{"root_position": [0, null, 0]}, {"root_position": [1, null, 0]}]}
Q
set +e
"$SEARCH" --index "$T/i.h5" --queries "$T/bad.jsonl" --out "$T/rb.jsonl" -q; rc=$?
set -e
[ "$rc" = 1 ] || { echo "expected exit 1, got $rc"; exit 1; }
python3 - "$T" <<'PY'
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1] + "/rb.jsonl")]
assert len(lines) == 5
assert "pairs" in lines[0] and "error" not in lines[0]
assert lines[1]["id"] == "joint" and "unknown joint" in lines[1]["error"] and "Hips" in lines[1]["error"]
assert lines[2]["id"] == "file" and "missing.bvh" in lines[2]["error"]
assert "error" in lines[3] and set(lines[3]) == {"id", "error"}
assert lines[4]["id"] == "character" and "no-such-character.json" in lines[4]["error"], lines[4]
PY
# A query character (tables recomputed for it, here on the Bandai Namco and
# CMU skeletons): answered; the query's own frames still come first and
# score about 0 (the database side is recomputed from the float32 poses).
C=$(cd "$(dirname "$0")/../.." && pwd)/docs/examples/character-heavy-arms.json
printf '{"id": "heavy", "relative": false, "character": "%s", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 3}\n' "$C" "$W" "$W" > "$T/char.jsonl"
"$SEARCH" --index "$T/i.h5" --queries "$T/char.jsonl" --threads 2 -q | python3 -c '
import json, sys
o = json.loads(sys.stdin.readline()); assert "error" not in o, o
top = o["pairs"][0]["results"][0]
assert top["clip"].endswith("dataset-1_walk_normal_001.bvh") and (top["start_frame"], top["end_frame"]) == (10, 40), top
assert abs(top["h_in_J"]) < 1e-2 and abs(top["h_out_J"]) < 1e-2, top'

# --query, modes, stdout.
printf '{"id": "one", "relative": false, "frames": [{"bvh": "%s", "frame": 5}, {"bvh": "%s", "frame": 25}], "top": 3}\n' "$W" "$W" > "$T/one.json"
"$SEARCH" --index "$T/i.h5" --query "$T/one.json" --mode approx -q | python3 -c '
import json, sys
o = json.loads(sys.stdin.readline()); assert o["id"] == "one" and 0 <= o["stats"]["recall"] <= 1, o'
"$SEARCH" --index "$T/i.h5" --query "$T/one.json" --mode brute -q > /dev/null
# Fatal: missing index -> 2.
set +e
"$SEARCH" --index "$T/nope.h5" --queries "$T/ok.jsonl" -q 2>/dev/null; rc=$?
set -e
[ "$rc" = 2 ] || { echo "expected exit 2 for a missing index, got $rc"; exit 1; }
# The energy subcommand still works.
"$SEARCH" energy --from "$W:10" --to "$W:20" --json > /dev/null
echo "search_batch: ok"
