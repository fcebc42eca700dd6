#!/usr/bin/env bash
# The demo's sample batch (docs/examples/queries.jsonl, @DATA@ filled in as
# scripts/demo does) against a set-1 + CMU index: every query answered, the
# ranking script prints every query and pair, and its exit statuses.
set -euo pipefail
BUILD=$1; DATA=$2
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
SEARCH=$BUILD/search/mocap-search; INDEXER=$BUILD/indexer/mocap-index
[ -d "$DATA/bandai-namco-1/data" ] && [ -d "$DATA/cmu" ] || { echo "no data at $DATA"; exit 77; }
[ -x "$SEARCH" ] && [ -x "$INDEXER" ] || { echo "binaries missing"; exit 77; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
"$INDEXER" build -q --out "$T/i.h5" "$DATA/bandai-namco-1" "$DATA/cmu" >/dev/null
D=$(cd "$DATA" && pwd | sed 's/[\\&|]/\\&/g')
sed "s|@DATA@|$D|g" "$SRC/docs/examples/queries.jsonl" > "$T/q.jsonl"
if grep -q "@DATA@" "$T/q.jsonl"; then echo "placeholder left"; exit 1; fi
"$SEARCH" --index "$T/i.h5" --queries "$T/q.jsonl" --out "$T/r.jsonl" -q
"$SRC/scripts/show-ranking" "$T/r.jsonl" > "$T/show.txt"
/usr/bin/python3 "$SRC/scripts/show-ranking" - < "$T/r.jsonl" | cmp - "$T/show.txt"
python3 - "$T" <<'PY'
import json, os, re, sys
t = sys.argv[1]
qs = [json.loads(l) for l in open(t + "/q.jsonl") if l.strip()]
rs = [json.loads(l) for l in open(t + "/r.jsonl")]
assert 4 <= len(qs) <= 6 and len(rs) == len(qs)
# The batch shows the documented features.
assert any(len(q["frames"]) == 3 for q in qs)
assert any(q.get("relative") for q in qs) and any("filter" in q for q in qs)
fr = [f for q in qs for f in q["frames"]]
assert any("bvh" in f and "only" not in f for f in fr) and any("only" in f for f in fr)
assert any(f.get("root_position", [0, 0, 0])[1] is None for f in fr)
assert any("euler_deg" in j and "order" in j for f in fr for j in f.get("joints", {}).values())
show = open(t + "/show.txt").read()
for q, r in zip(qs, rs):
    assert "error" not in r and r["id"] == q["id"], r
    assert len(r["pairs"]) == len(q["frames"]) - 1
    assert ("query %s: %d pair(s)" % (q["id"], len(r["pairs"]))) in show
    for p in r["pairs"]:
        res = p["results"]
        assert 1 <= len(res) <= q.get("top", 10)
        assert [x["rank"] for x in res] == list(range(1, len(res) + 1))
        # Results meeting the request first (docs/queries.md "Residuals and
        # verdicts"), each group by score.
        key = [(not x.get("met", True), x["score_J"]) for x in res]
        assert key == sorted(key), key
        for x in res:
            # One ranking row per result: rank, file name, labels, s-e, score,
            # and for constrained queries whether it meets the request.
            lab = " / ".join(v for k, v in sorted(x["labels"].items()) if v) or "-"
            verdict = r"\s+(met|MISS .+)\s*" if "met" in x else ""
            row = r"^\s+%d\s+%s\s+%s\s+%d-%d\s+%.1f" % (
                x["rank"], re.escape(os.path.basename(x["clip"])), re.escape(lab),
                x["start_frame"], x["end_frame"], x["score_J"]) + verdict + "$"
            assert re.search(row, show, re.M), (row, show)
        assert ("Q%d -> Q%d: %d result(s)" % (p["from"] + 1, p["to"] + 1, len(res))) in show
# The full-frame walk query finds its own frames first, at zero energy.
w = rs[0]["pairs"][0]["results"][0]
assert w["clip"].endswith("dataset-1_walk_normal_001.bvh") and abs(w["score_J"]) < 1e-6, w
# Filters held.
for q, r in zip(qs, rs):
    for x in (x for p in r["pairs"] for x in p["results"]):
        c = q.get("filter", {}).get("content")
        assert not c or x["labels"]["content"] in c, (q["id"], x)
print("sample batch: %d queries, %d pairs answered" % (len(rs), sum(len(r["pairs"]) for r in rs)))
PY
# Error lines are shown and give exit 1; unreadable input exit 2.
printf '{"id": "bad", "error": "boom"}\n' > "$T/e.jsonl"
set +e
"$SRC/scripts/show-ranking" "$T/e.jsonl" > "$T/e.txt"; rc1=$?
echo 'not json' | "$SRC/scripts/show-ranking" 2>/dev/null; rc2=$?
"$SRC/scripts/show-ranking" "$T/missing.jsonl" 2>/dev/null; rc3=$?
set -e
[ "$rc1" = 1 ] && grep -q "query bad: ERROR boom" "$T/e.txt" || { echo "error line: rc $rc1"; exit 1; }
[ "$rc2" = 2 ] && [ "$rc3" = 2 ] || { echo "bad input: rc $rc2 $rc3"; exit 1; }
echo "demo_queries: ok"
