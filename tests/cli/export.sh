#!/usr/bin/env bash
# mocap-search export on set 1: invalid inputs first (unknown clip, frames out
# of range, S > E, missing --id / --pair / --rank, both or neither route: exit
# 2, a clear message, nothing written), then a partial motion of a search's
# results exported by clip and frames and from the results line (the same
# bytes, also from a collection of the clip's shard), whose joint positions
# (mocap-index inspect of the exported file) are the source clip's frames to
# 1e-5 m, and the output path rules (a BVH replaced, another file refused
# without --force).
#   bash tests/cli/export.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup export "$@"
d="$data/bandai-namco-1/data"
"$indexer" build -q --out "$tmp/set1.h5" "$d" >/dev/null 2>&1 || fail "indexing set 1 failed"
w="$d/dataset-1_walk_normal_001.bvh"
cat >"$tmp/q.jsonl" <<Q
{"id": "walk", "relative": false, "frames": [{"bvh": "$w", "frame": 10}, {"bvh": "$w", "frame": 40}, {"bvh": "$w", "frame": 70}], "top": 5}
Q
"$search" --index "$tmp/set1.h5" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" -q

# Invalid inputs: exit 2, the message, no output file.
expect_usage_error() {  # expect_usage_error PATTERN ARGS...
  local pattern="$1" rc=0
  shift
  "$search" export --index "$tmp/set1.h5" --out "$tmp/bad.bvh" "$@" >"$tmp/out.txt" 2>"$tmp/err.txt" || rc=$?
  [ "$rc" = 2 ] || { cat "$tmp/err.txt" >&2; fail "exit $rc (expected 2) for: $*"; }
  grep -qF -- "$pattern" "$tmp/err.txt" || { cat "$tmp/err.txt" >&2; fail "message '$pattern' missing for: $*"; }
  [ ! -e "$tmp/bad.bvh" ] || fail "an output was written by: $*"
}
expect_usage_error 'no clip "dataset-1_walk_normal_01.bvh"' --clip dataset-1_walk_normal_01.bvh --frames 0-10
expect_usage_error 'close names: dataset-1_walk_normal_001.bvh' --clip dataset-1_walk_normal_01.bvh --frames 0-10
expect_usage_error "set1.h5: no clip" --clip nothing-like-it.bvh --frames 0-10
expect_usage_error 'out of range for' --clip dataset-1_walk_normal_001.bvh --frames 10-999999
expect_usage_error 'first frame 40 is after last frame 10' --clip dataset-1_walk_normal_001.bvh --frames 40-10
expect_usage_error '--frames: expected S-E' --clip dataset-1_walk_normal_001.bvh --frames 10
expect_usage_error '--frames: required with --clip' --clip dataset-1_walk_normal_001.bvh
expect_usage_error '--id: required with --results' --results "$tmp/r.jsonl" --pair 1 --rank 1
expect_usage_error '--pair: required with --results' --results "$tmp/r.jsonl" --id walk --rank 1
expect_usage_error '--rank: required with --results' --results "$tmp/r.jsonl" --id walk --pair 1
expect_usage_error '--pair: expected a pair number' --results "$tmp/r.jsonl" --id walk --pair 0 --rank 1
expect_usage_error 'r.jsonl:1: query "walk": pair 3 out of range' --results "$tmp/r.jsonl" --id walk --pair 3 --rank 1
expect_usage_error 'r.jsonl:1: query "walk", pair 1: no result of rank 9' --results "$tmp/r.jsonl" --id walk --pair 1 --rank 9
expect_usage_error 'no results for query "run"' --results "$tmp/r.jsonl" --id run --pair 1 --rank 1
expect_usage_error 'not both' --clip dataset-1_walk_normal_001.bvh --frames 0-10 --results "$tmp/r.jsonl" --id walk --pair 1 --rank 1
expect_usage_error 'give --clip NAME --frames S-E, or --results'
rc=0; "$search" export --clip dataset-1_walk_normal_001.bvh --frames 0-1 --out "$tmp/bad.bvh" 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -qF -- "--index: required" "$tmp/err.txt" || fail "no --index: exit $rc, $(cat "$tmp/err.txt")"

# Pair 2, rank 2 of the results, exported both ways: the same bytes.
read -r clip s e < <(python3 - "$tmp/r.jsonl" <<'PY'
import json, sys
r = json.loads(open(sys.argv[1]).readline())["pairs"][1]["results"]
m = next(x for x in r if x["rank"] == 2)
print(m["clip"], m["start_frame"], m["end_frame"])
PY
)
"$search" export --index "$tmp/set1.h5" --results "$tmp/r.jsonl" --id walk --pair 2 --rank 2 \
  --out "$tmp/from-results.bvh" >"$tmp/out.txt"
grep -qF "motion: $tmp/from-results.bvh ($((e - s + 1)) frames: $clip frames $s-$e)" "$tmp/out.txt" ||
  fail "unexpected summary: $(cat "$tmp/out.txt")"
"$search" export --index "$tmp/set1.h5" --clip "$clip" --frames "$s-$e" --out "$tmp/by-path.bvh" >/dev/null
"$search" export --index "$tmp/set1.h5" --clip "$(basename "$clip")" --frames "$s-$e" --out "$tmp/by-name.bvh" >/dev/null
cmp -s "$tmp/from-results.bvh" "$tmp/by-path.bvh" || fail "--results and --clip (path) differ"
cmp -s "$tmp/from-results.bvh" "$tmp/by-name.bvh" || fail "--results and --clip (file name) differ"
# A collection (two shards, the clip in one of them) writes the same bytes.
"$indexer" build -q --shards 2 --out "$tmp/c2.json" "$clip" "$w" "$d/dataset-1_bow_active_001.bvh" >/dev/null 2>&1
"$search" export --index "$tmp/c2.json" --clip "$(basename "$clip")" --frames "$s-$e" --out "$tmp/from-collection.bvh" >/dev/null
cmp -s "$tmp/from-results.bvh" "$tmp/from-collection.bvh" || fail "a collection wrote other bytes"
# Results of a search over the collection (its clip numbers) name the same frames.
"$search" --index "$tmp/c2.json" --queries "$tmp/q.jsonl" --out "$tmp/rc.jsonl" -q
read -r cclip cs ce < <(python3 -c 'import json, sys; m = json.loads(open(sys.argv[1]).readline())["pairs"][0]["results"][1]; print(m["clip"], m["start_frame"], m["end_frame"])' "$tmp/rc.jsonl")
"$search" export --index "$tmp/c2.json" --results "$tmp/rc.jsonl" --id walk --pair 1 --rank 2 --out "$tmp/c-results.bvh" >/dev/null
"$search" export --index "$tmp/set1.h5" --clip "$cclip" --frames "$cs-$ce" --out "$tmp/c-direct.bvh" >/dev/null
cmp -s "$tmp/c-results.bvh" "$tmp/c-direct.bvh" || fail "results over a collection name other frames"

# Joint positions of every exported frame = the source clip's frames s..e.
for ((k = 0; k <= e - s; ++k)); do
  "$indexer" inspect "$tmp/from-results.bvh" --frame "$k" --json >"$tmp/x-$k.json"
  "$indexer" inspect "$clip" --frame "$((s + k))" --json >"$tmp/c-$k.json"
done
python3 - "$tmp" "$((e - s + 1))" <<'PY'
import json, sys
tmp, n = sys.argv[1], int(sys.argv[2])
worst = 0.0
for k in range(n):
    x = json.load(open(f"{tmp}/x-{k}.json"))
    c = json.load(open(f"{tmp}/c-{k}.json"))
    assert x["frames"] == n and abs(x["frame_time_s"] - c["frame_time_s"]) < 1e-9, (x["frames"], n)
    assert [j["name"] for j in x["joints"]] == [j["name"] for j in c["joints"]]
    for a, b in zip(x["joints"], c["joints"]):
        worst = max(worst, max(abs(p - q) for p, q in zip(a["position_m"], b["position_m"])))
assert worst < 1e-5, worst
print(f"export: {n} frames, joint positions within {worst:.2e} m of the source")
PY

# Output paths: a BVH is replaced; another file is refused without --force.
"$search" export --index "$tmp/set1.h5" --clip "$clip" --frames "0-3" --out "$tmp/by-path.bvh" >/dev/null
[ "$(sed -n 's/^Frames: //p' "$tmp/by-path.bvh")" = 4 ] || fail "the BVH output was not replaced"
echo '{"keep": true}' >"$tmp/keep.json"
rc=0; "$search" export --index "$tmp/set1.h5" --clip "$clip" --frames "0-3" --out "$tmp/keep.json" 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q -- "--out" "$tmp/err.txt" || fail "a JSON file was not refused (exit $rc)"
grep -q keep "$tmp/keep.json" || fail "the refused output changed"
"$search" export --index "$tmp/set1.h5" --clip "$clip" --frames "0-3" --out "$tmp/keep.json" --force >/dev/null
head -1 "$tmp/keep.json" | grep -q HIERARCHY || fail "--force did not replace the file"
echo "export ok"
