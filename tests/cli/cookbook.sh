#!/usr/bin/env bash
# The query cookbook (docs/queries.md "Cookbook", docs/examples/cookbook.jsonl)
# against a set-1 index: every request answered; at least 10 of the 12
# retrieve their intended content among the top 3 (the issue's goal; all 12
# do today, and each is checked); constrained requests report residuals by
# name on both sides; the page documents every request. Verdicts (docs/queries.md "Residuals and
# verdicts"): every constrained result says whether it meets each
# constraint; "met": "only" gives each clip's best partial motion that meets
# them, "first" (the default) those and then the other clips' best by score,
# "any" every clip's best by score; the top 3 of each equal the same ranking
# of every clip (searches with top 400 > 174 clips); show-ranking names the
# misses.
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

# Verdicts and the three rankings against a reference over every clip.
for run in first only any only-all; do
  /usr/bin/python3 - "$SRC/docs/examples/cookbook.jsonl" "$run" "$T/q-$run.jsonl" <<'PY'
import json, sys
with open(sys.argv[3], "w") as out:
    for line in open(sys.argv[1]):
        if line.strip():
            q = json.loads(line)
            q["met"] = sys.argv[2].split("-")[0]
            if sys.argv[2] in ("any", "only-all"):
                q["top"] = 400  # every clip: the reference
            out.write(json.dumps(q) + "\n")
PY
  "$SEARCH" --index "$T/i.h5" --queries "$T/q-$run.jsonl" --out "$T/r-$run.jsonl" -q
done
/usr/bin/python3 - "$T" <<'PY'
import json, sys
t = sys.argv[1]
load = lambda name: [json.loads(l) for l in open(t + "/" + name)]
every, met_every, default = load("r-any.jsonl"), load("r-only-all.jsonl"), load("r.jsonl")
runs = {p: load("r-%s.jsonl" % p) for p in ("first", "only")}
def key(policy):
    return lambda x: ((not x["met"]) if policy != "any" else False, x["score_J"], x["misfit"],
                      x["clip_index"], x["end_frame"], x["start_frame"])
ident = lambda x: (x["clip_index"], x["start_frame"], x["end_frame"])
misses = checked = 0
for i, all_r in enumerate(every):
    for h, pair in enumerate(all_r["pairs"]):
        allres = pair["results"]
        assert len(allres) < 400
        if not any("verdicts" in x for x in allres):
            continue
        for x in allres:
            assert sorted(x["verdicts"]) == sorted(x["residuals"]), x
            for side, vs in x["verdicts"].items():
                assert sorted(vs) == sorted(x["residuals"][side])
                for name, v in vs.items():
                    floor = 0.01 if v["unit"] == "m" else 1.0
                    assert abs(v["limit"] - max(v["tolerance"], floor)) < 1e-12, v
                    assert v["met"] == (v["residual"] <= v["limit"]), v
                    assert v["residual"] == x["residuals"][side][name]
            assert x["met"] == all(v["met"] for vs in x["verdicts"].values() for v in vs.values())
        misses += sum(not x["met"] for x in allres)
        # Each top 400 is in its own order; each policy's top 3 is the same
        # ranking of every clip.
        met_all = met_every[i]["pairs"][h]["results"]
        assert all(x["met"] for x in met_all), met_every[i]["id"]
        for res, policy in ((allres, "any"), (met_all, "only")):
            assert [ident(x) for x in res] == [ident(x) for x in sorted(res, key=key(policy))]
        met_clips = {x["clip_index"] for x in met_all}
        ref_of = {"only": met_all[:3],
                  "first": (met_all + [x for x in allres if x["clip_index"] not in met_clips])[:3]}
        for policy, run in runs.items():
            got = run[i]["pairs"][h]["results"]
            assert [ident(x) for x in got] == [ident(x) for x in ref_of[policy]], (run[i]["id"], policy)
            assert [x["rank"] for x in got] == list(range(1, len(got) + 1))
        assert default[i]["pairs"][h]["results"] == runs["first"][i]["pairs"][h]["results"]
        checked += 1
assert misses > 0, "no constrained result misses: the check would not see a wrong order"
print("verdict rankings equal the reference on %d pairs; %d misses among every clip's best"
      % (checked, misses))
PY
# show-ranking names what a result misses.
"$SRC/scripts/show-ranking" "$T/r-any.jsonl" >"$T/show.txt"
grep -q "request" "$T/show.txt" || { echo "show-ranking has no request column"; exit 1; }
grep -Eq "MISS (from|to) [a-zA-Z_]+ [0-9.]+ (m|deg) > [0-9.]+ (m|deg)" "$T/show.txt" ||
  { echo "show-ranking names no miss:"; cat "$T/show.txt"; exit 1; }
# The HTML ranking shows them too (a badge on each figure, the misses in
# the legend), and the page made from the results file is the same.
if [ -f "$SRC/common/player/web/node_modules/three/build/three.module.js" ]; then
  head -n 1 "$T/q-any.jsonl" | sed 's/"top": 400/"top": 40/' >"$T/q-bow.jsonl"
  "$SEARCH" --index "$T/i.h5" --queries "$T/q-bow.jsonl" --out "$T/bow.jsonl" --html "$T/bow.html" -q
  grep -q '\\u2717\|\xe2\x9c\x97' "$T/bow.html" || grep -q "✗" "$T/bow.html" ||
    { echo "the HTML ranking has no miss badge"; exit 1; }
  grep -q "misses to trunk_flexion" "$T/bow.html" || { echo "the HTML ranking names no miss"; exit 1; }
  grep -q "meets the request" "$T/bow.html" || { echo "the HTML ranking names no met result"; exit 1; }
  MOCAP_BUILD_DIR="$BUILD" "$SRC/scripts/view" "$T/bow.jsonl" --index "$T/i.h5" --out "$T/view.html" >/dev/null
  cmp -s "$T/bow.html" "$T/view.html" || { echo "scripts/view and mocap-search --html differ"; exit 1; }
fi
echo "ok"
