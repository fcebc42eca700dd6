#!/usr/bin/env bash
# mocap-index style-model and mocap-search style on set 1 (docs/style.md):
# invalid inputs first (an index without labels, a missing or broken model,
# a file of another rig, frames out of range: exit 2 and a message naming
# the file or option, nothing written), then a model learned from set 1
# (--evaluate: leave one take out, at least 0.7 of the takes named right),
# the style of a file and of a frame range (text and JSON: the style is the
# most probable, the probabilities sum to 1), the same through --index
# (the clip read from the index, its content label used), the output path
# rules (a model replaced, another file refused without --force), and
# search results carrying their recognised style (--style-model), a query
# asking for a style, and a synthesis report's styles (mocap-synth
# --style-model); style transfer (mocap-synth --style, a query's
# "synth_style"): its errors, its report, a batch equal to single runs.
#   bash tests/cli/style.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup style "$@"
d="$data/bandai-namco-1/data"
"$indexer" build -q --out "$tmp/set1.h5" "$d" >/dev/null 2>&1 || fail "indexing set 1 failed"
"$indexer" build -q --out "$tmp/cmu.h5" "$data/cmu" >/dev/null 2>&1 || fail "indexing cmu failed"

expect_error() {  # expect_error PATTERN COMMAND...
  local pattern="$1" rc=0
  shift
  "$@" >"$tmp/out.txt" 2>"$tmp/err.txt" || rc=$?
  [ "$rc" = 2 ] || { cat "$tmp/err.txt" >&2; fail "exit $rc (expected 2) for: $*"; }
  grep -qF -- "$pattern" "$tmp/err.txt" || { cat "$tmp/err.txt" >&2; fail "message '$pattern' missing for: $*"; }
}
expect_error 'no clip has both a "content" and a "style" label' \
  "$indexer" style-model "$tmp/cmu.h5" --out "$tmp/cmu-style.json"
[ ! -e "$tmp/cmu-style.json" ] || fail "a model was written for an index without labels"
expect_error "nothing.h5" "$indexer" style-model "$tmp/nothing.h5" --out "$tmp/x.json"
echo "not a model" >"$tmp/notes.txt"
expect_error "--out" "$indexer" style-model "$tmp/set1.h5" --out "$tmp/notes.txt"
grep -q "not a model" "$tmp/notes.txt" || fail "another file was replaced"

"$indexer" style-model "$tmp/set1.h5" --out "$tmp/style.json" --evaluate --json >"$tmp/model.json"
python3 - "$tmp/model.json" <<'PY' || fail "style-model --json"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["clips"] == 174 and len(r["styles"]) == 15, r
e = r["evaluation"]
assert e["takes"] + e["alone"] == 174 and e["accuracy"] >= 0.7, e
assert sum(sum(row.values()) for row in e["confusion"].values()) == e["takes"]
PY
# Replacing its own model is allowed.
"$indexer" style-model "$tmp/set1.h5" --out "$tmp/style.json" >"$tmp/out.txt"
grep -q "style model: .*style.json (174 clips, 15 styles" "$tmp/out.txt" || fail "style-model text"

expect_error "cannot read the style model" "$search" style --model "$tmp/none.json" "$d/dataset-1_walk_old_001.bvh"
expect_error "not JSON" "$search" style --model "$tmp/notes.txt" "$d/dataset-1_walk_old_001.bvh"
expect_error 'no joint "Spine"' "$search" style --model "$tmp/style.json" "$data/cmu/131_01.bvh"
expect_error "outside the clip" "$search" style --model "$tmp/style.json" "$d/dataset-1_walk_old_001.bvh:10-99999"
expect_error "need at least 4" "$search" style --model "$tmp/style.json" "$d/dataset-1_walk_old_001.bvh:10-11"
expect_error "no content" "$search" style --model "$tmp/style.json" --content swim "$d/dataset-1_walk_old_001.bvh"

"$search" style --model "$tmp/style.json" "$d/dataset-1_walk_old_001.bvh" >"$tmp/out.txt"
grep -q "dataset-1_walk_old_001.bvh: old (p = " "$tmp/out.txt" || { cat "$tmp/out.txt"; fail "style text"; }
"$search" style --model "$tmp/style.json" "$d/dataset-1_walk_old_001.bvh:10-80" --json >"$tmp/a.json"
"$search" style --model "$tmp/style.json" --index "$tmp/set1.h5" "$d/dataset-1_walk_old_001.bvh:10-80" --json >"$tmp/b.json"
python3 - "$tmp/a.json" "$tmp/b.json" <<'PY' || fail "style --json"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
for r in (a, b):
    assert r["frames"] == [10, 80] and r["style"] == max(r["probabilities"], key=r["probabilities"].get), r
    assert abs(sum(r["probabilities"].values()) - 1) < 1e-9 and len(r["probabilities"]) == 15
assert a["content_recognised"] and not b["content_recognised"] and b["content"] == "walk", b
PY
# Search results with their recognised style (--style-model): every result
# of a walk query carries one of the model's styles; on the clips the model
# learned from, their own label in at least 8 of 10.
w="$d/dataset-1_walk_old_001.bvh"
cat >"$tmp/q.jsonl" <<Q
{"id": "oldwalk", "top": 10, "filter": {"exclude": ["dataset-1_walk_old_001*"]}, "frames": [{"bvh": "$w", "frame": 20}, {"bvh": "$w", "frame": 60}]}
Q
expect_error "cannot read the style model" "$search" --index "$tmp/set1.h5" --queries "$tmp/q.jsonl" --style-model "$tmp/none.json" --out "$tmp/none.jsonl"
[ ! -e "$tmp/none.jsonl" ] || fail "results were written with a missing style model"
"$search" --index "$tmp/set1.h5" --queries "$tmp/q.jsonl" --style-model "$tmp/style.json" --out "$tmp/r.jsonl" -q
python3 - "$tmp/r.jsonl" "$tmp/a.json" <<'PY' || fail "--style-model results"
import json, sys
line = json.loads(open(sys.argv[1]).readline())
styles = json.load(open(sys.argv[2]))["probabilities"].keys()
results = line["pairs"][0]["results"]
assert len(results) == 10
for r in results:
    s = r["recognised_style"]
    assert s["label"] in styles and 0 < s["p"] <= 1, r
assert sum(r["recognised_style"]["label"] == r["labels"]["style"] for r in results) >= 8, results
PY
"$search" --index "$tmp/set1.h5" --queries "$tmp/q.jsonl" --out "$tmp/plain.jsonl" -q
grep -q recognised_style "$tmp/plain.jsonl" && fail "recognised_style without --style-model"
# A query asking for a style: style_J on every result, the old takes first;
# without --style-model the query fails (exit 1, its error line).
cat >"$tmp/qs.jsonl" <<Q
{"id": "asked", "top": 5, "filter": {"exclude": ["dataset-1_walk_old_001*"]}, "style": {"label": "old", "weight": 20}, "frames": [{"bvh": "$w", "frame": 20}, {"bvh": "$w", "frame": 60}]}
Q
"$search" --index "$tmp/set1.h5" --queries "$tmp/qs.jsonl" --style-model "$tmp/style.json" --out "$tmp/rs.jsonl" -q
python3 - "$tmp/rs.jsonl" <<'PY' || fail "a query with style"
import json, sys
results = json.loads(open(sys.argv[1]).readline())["pairs"][0]["results"]
assert all(r["style_J"] >= 0 for r in results), results
assert [r["labels"]["style"] for r in results[:3]] == ["old"] * 3, results
PY
rc=0
"$search" --index "$tmp/set1.h5" --queries "$tmp/qs.jsonl" --out "$tmp/rs2.jsonl" -q 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] || fail "a style query without --style-model: exit $rc (expected 1)"
grep -q "needs a style model" "$tmp/rs2.jsonl" || fail "the error line of a style query without a model"
# A synthesis report with the styles of the output and its partial motion.
python3 - "$w" "$tmp/synth-q.json" <<'PY'
import json, sys
json.dump({"id": "oldwalk", "filter": {"exclude": ["dataset-1_walk_old_001*"]},
           "frames": [{"bvh": sys.argv[1], "frame": 20, "time_s": 0},
                      {"bvh": sys.argv[1], "frame": 50, "time_s": 1.0}]}, open(sys.argv[2], "w"))
PY
# (mocap-synth --query has no partial success: any error exits 1, docs/cli.md)
rc=0
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/m.bvh" \
  --style-model "$tmp/none.json" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q "cannot read the style model" "$tmp/err.txt" ||
  fail "mocap-synth with a missing style model: exit $rc"
[ ! -e "$tmp/m.bvh" ] || fail "a motion was written with a missing style model"
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/m.bvh" \
  --report "$tmp/report.json" --style-model "$tmp/style.json" >/dev/null 2>&1
python3 - "$tmp/report.json" "$tmp/a.json" <<'PY' || fail "the report's styles"
import json, sys
styles = json.load(open(sys.argv[1]))["styles"]
known = json.load(open(sys.argv[2]))["probabilities"].keys()
assert [s["of"] for s in styles] == ["motion", "partial 1"], styles
assert all(s["label"] in known and 0 < s["p"] <= 1 for s in styles), styles
PY

# Style transfer (docs/style.md "Style transfer"): errors naming the option
# (exit 1, nothing written), then a single run's report and a batch equal to
# single runs byte for byte, a query's "synth_style" replacing --style.
rc=0
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/t.bvh" --style old \
  >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q -- "--style: needs --style-model" "$tmp/err.txt" ||
  { cat "$tmp/err.txt" >&2; fail "--style without --style-model: exit $rc"; }
rc=0
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/t.bvh" --style elderly \
  --style-model "$tmp/style.json" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q 'no style "elderly"; its styles: active, angry' "$tmp/err.txt" ||
  { cat "$tmp/err.txt" >&2; fail "--style the model lacks: exit $rc"; }
rc=0
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/t.bvh" --style old \
  --style-strength 5 --style-model "$tmp/style.json" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q -- "--style-strength: must be a number from 0 to 4" "$tmp/err.txt" ||
  { cat "$tmp/err.txt" >&2; fail "--style-strength 5: exit $rc"; }
python3 - "$data/cmu/131_01.bvh" "$tmp/cmu-q.json" <<'PY'
import json, sys
json.dump({"id": "cmu", "frames": [{"bvh": sys.argv[1], "frame": 20, "time_s": 0},
                                   {"bvh": sys.argv[1], "frame": 50, "time_s": 0.25}]},
          open(sys.argv[2], "w"))
PY
rc=0
"$synth" --index "$tmp/cmu.h5" --query "$tmp/cmu-q.json" --out "$tmp/t.bvh" --style old \
  --style-model "$tmp/style.json" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q -- "--style-model: the model's joint .* a model of another rig" "$tmp/err.txt" ||
  { cat "$tmp/err.txt" >&2; fail "--style with a model of another rig: exit $rc"; }
[ ! -e "$tmp/t.bvh" ] || fail "a motion was written by a refused transfer"
"$synth" --index "$tmp/set1.h5" --query "$tmp/synth-q.json" --out "$tmp/t.bvh" --style old \
  --report "$tmp/t.json" --html "$tmp/t.html" --style-model "$tmp/style.json" >"$tmp/out.txt" 2>&1 ||
  fail "--style old"
grep -q "^style:  toward old (recognised before: .*; after: .*held where the untransferred feet are" \
  "$tmp/out.txt" || { cat "$tmp/out.txt"; fail "the printed style line"; }
# The HTML report says it too: the output's style, its partial motion's, the transfer.
grep -q '<p data-figure="styles"><b>Style</b>.*output: .*partial 1: .*turned toward old (strength 1.00; before the transfer: ' \
  "$tmp/t.html" || fail "the HTML report's style paragraph"
python3 - "$tmp/t.json" "$tmp/report.json" <<'PY' || fail "the transfer's report"
import json, sys
t, plain = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
s = t["style_transfer"]
assert s["style"] == "old" and s["strength"] == 1 and s["content"] == "walk", s
assert [x["of"] for x in t["styles"][:2]] == ["motion", "motion before transfer"], t["styles"]
assert t["styles"][1] == dict(plain["styles"][0], of="motion before transfer"), t["styles"]
assert t["motion"]["foot_skating_ratio"] <= plain["motion"]["foot_skating_ratio"] + 0.01
PY
python3 - "$w" "$tmp/tq.jsonl" <<'PY'
import json, sys
base = {"filter": {"exclude": ["dataset-1_walk_old_001*"]},
        "frames": [{"bvh": sys.argv[1], "frame": 20, "time_s": 0},
                   {"bvh": sys.argv[1], "frame": 50, "time_s": 1.0}]}
with open(sys.argv[2], "w") as f:
    f.write(json.dumps(dict(base, id="as-asked")) + "\n")
    f.write(json.dumps(dict(base, id="tired", synth_style="tired")) + "\n")
PY
"$synth" --index "$tmp/set1.h5" --queries "$tmp/tq.jsonl" --out-dir "$tmp/tb" --style old \
  --style-model "$tmp/style.json" --reports -q >/dev/null 2>&1 || fail "a batch with --style"
for id in as-asked tired; do
  "$synth" --index "$tmp/set1.h5" --query "$tmp/tq.jsonl" --id "$id" --out "$tmp/t-$id.bvh" \
    --style old --style-model "$tmp/style.json" >/dev/null 2>&1 || fail "$id alone"
  cmp -s "$tmp/t-$id.bvh" "$tmp/tb/$id.bvh" || fail "$id: the batch's motion is not the single run's"
done
python3 - "$tmp/tb/as-asked.json" "$tmp/tb/tired.json" <<'PY' || fail "the batch's styles asked"
import json, sys
assert json.load(open(sys.argv[1]))["style_transfer"]["style"] == "old"
assert json.load(open(sys.argv[2]))["style_transfer"]["style"] == "tired"
PY
# A query asking for a style (retrieval, docs/style.md "Asking for a
# style") in mocap-synth: its search gets the model (single and batch, the
# batch equal to the single run), and fails naming --style-model without it.
python3 - "$w" "$tmp/ask.jsonl" <<'PY'
import json, sys
q = {"id": "ask-old", "filter": {"exclude": ["dataset-1_walk_old_001*"]},
     "style": {"label": "old", "weight": 20},
     "frames": [{"bvh": sys.argv[1], "frame": 20, "time_s": 0},
                {"bvh": sys.argv[1], "frame": 50, "time_s": 1.0}]}
open(sys.argv[2], "w").write(json.dumps(q) + "\n")
PY
rc=0
"$synth" --index "$tmp/set1.h5" --query "$tmp/ask.jsonl" --out "$tmp/ask.bvh" \
  >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 1 ] && grep -q "style-model" "$tmp/err.txt" ||
  fail "mocap-synth, a style query without --style-model: exit $rc, $(cat "$tmp/err.txt")"
"$synth" --index "$tmp/set1.h5" --query "$tmp/ask.jsonl" --out "$tmp/ask.bvh" \
  --report "$tmp/ask.json" --style-model "$tmp/style.json" >/dev/null 2>"$tmp/err.txt" ||
  fail "mocap-synth, a style query with --style-model: $(cat "$tmp/err.txt")"
"$synth" --index "$tmp/set1.h5" --queries "$tmp/ask.jsonl" --out-dir "$tmp/askb" \
  --style-model "$tmp/style.json" -q >/dev/null 2>&1 || fail "a batch of a style query"
cmp -s "$tmp/ask.bvh" "$tmp/askb/ask-old.bvh" || fail "the style query's batch motion"
echo "style: ok"
