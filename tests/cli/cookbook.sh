#!/usr/bin/env bash
# The query cookbook (docs/queries.md "Cookbook", docs/examples/cookbook.jsonl)
# against a set-1 index: every request answered; at least 10 of the 12
# retrieve their intended content among the top 3 (the issue's goal; all 12
# do today, and each is checked); constrained requests report residuals by
# name on both sides; the page documents every request.
set -euo pipefail
BUILD=$1; DATA=$2
SRC=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
SEARCH=$BUILD/search/mocap-search; INDEXER=$BUILD/indexer/mocap-index
[ -d "$DATA/bandai-namco-1/data" ] || { echo "no data at $DATA"; exit 77; }
[ -x "$SEARCH" ] && [ -x "$INDEXER" ] || { echo "binaries missing"; exit 77; }
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
"$INDEXER" build -q --out "$T/i.h5" "$DATA/bandai-namco-1/data" >/dev/null
"$SEARCH" --index "$T/i.h5" --queries "$SRC/docs/examples/cookbook.jsonl" --out "$T/r.jsonl" -q
/usr/bin/python3 - "$T/r.jsonl" "$SRC/docs/examples/cookbook.jsonl" "$SRC/docs/queries.md" <<'PY'
import json, sys
results, queries, page = sys.argv[1], sys.argv[2], open(sys.argv[3]).read()
# The content each request is meant to retrieve (set 1's labels). Set 1 has
# no turning or crouching clips: its 90-degree turns are the actors turning
# away at the end of bows, its deep knee bends are in the dance and in the
# "happy" byes and guides.
intended = {
    "bow": {"bow"},
    "wave-at-head-height": {"bye", "byebye"},
    "turn-90-left": {"bow"},
    "crouch": {"dance-short", "byebye", "guide"},
    "step-back": {"walk-back"},
    "kick": {"kick"},
    "run-3m-in-1s": {"run", "dash"},
    "reach-forward": {"guide"},
    "jab": {"punch"},
    "walk-forward": {"walk", "walk-left", "walk-right"},
    "slash-down": {"slash"},
    "both-arms-up": {"byebye"},
}
qs = [json.loads(l) for l in open(queries) if l.strip()]
rs = [json.loads(l) for l in open(results)]
assert [q["id"] for q in qs] == list(intended), [q["id"] for q in qs]
assert len(rs) == len(qs) == 12
hits = 0
for q, r in zip(qs, rs):
    assert "error" not in r and r["id"] == q["id"], r
    assert "`%s`" % q["id"] in page, "docs/queries.md does not show " + q["id"]
    top = r["pairs"][0]["results"]
    assert len(top) == 3, (q["id"], len(top))
    got = [x["labels"].get("content") for x in top]
    ok = bool(intended[q["id"]] & set(got))
    hits += ok
    print("%-20s %-4s %s" % (q["id"], "ok" if ok else "MISS", ", ".join(map(str, got))))
    # Named constraints are measured on both sides of every result.
    for side, frame in (("from", q["frames"][0]), ("to", q["frames"][1])):
        names = [n for key in ("angles", "effectors", "joints") for n in frame.get(key, {})]
        for x in top:
            res = x.get("residuals", {}).get(side, {})
            assert sorted(res) == sorted(names), (q["id"], side, res, names)
            assert all(v >= 0 for v in res.values()), res
print("intended content in the top 3: %d of %d" % (hits, len(qs)))
assert hits == len(qs), "a cookbook request no longer retrieves its intended content"
PY
