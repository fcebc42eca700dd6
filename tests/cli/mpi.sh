#!/usr/bin/env bash
# mocap-search under mpirun (docs/search.md "Many machines: MPI"): 2 ranks
# over 2- and 3-shard collections of set 1, distributed by shards and by
# queries, give rank 0 an output equal to brute force over the single index
# (but for the stats) on held-out queries of every kind; a failing rank (a missing shard,
# a changed shard, an output path refused on rank 0 (a shard of the
# collection read, even with --force), an unreadable batch) ends the whole
# job with exit 2 and a message naming the rank and the file, never a hang;
# a rank killed mid-run leaves no temporary results file; style queries
# (a style model, a style asked by label and like a file) equal one process.
#   bash tests/cli/mpi.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup mpi "$@"
set1="$data/bandai-namco-1"
command -v mpirun >/dev/null || missing_tool scripts/setup "mpirun (Open MPI) is not installed"
ldd "$search" | grep libmpi >/dev/null ||  # not grep -q: ldd must not die of SIGPIPE under pipefail
  missing_tool scripts/setup "mocap-search was built without MPI"
# Open MPI refuses root without these (CI runs as root); --oversubscribe lets
# 2 ranks share fewer cores.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
# Each run is bounded: a hang fails the test instead of stalling CI.
mpi() { timeout 300 mpirun -np "$1" "${@:2}"; }

"$indexer" build -q --out "$tmp/one.h5" "$set1" >/dev/null
for n in 2 3; do "$indexer" build -q --shards "$n" --out "$tmp/c$n.json" "$set1" >/dev/null; done
python3 "$(dirname "${BASH_SOURCE[0]}")/../../bench/search_queries.py" "$(cd "$set1/data" && pwd)" 40 11 >"$tmp/q.jsonl"
# A line that cannot be parsed: every rank reports it the same way.
echo '{"id": "broken", "frames": 3}' >>"$tmp/q.jsonl"
# The reference: brute force in one process over the single index (exact
# equals it bit for bit, so every MPI run below must too).
status=0
"$search" -q --mode brute --index "$tmp/one.h5" --queries "$tmp/q.jsonl" --out "$tmp/r1.jsonl" ||
  status=$?
[ "$status" -eq 1 ] || fail "one process: exit $status (expected 1: one line fails)"

same() {  # same RESULTS_A RESULTS_B WHAT
  python3 - "$1" "$2" <<'PY' || fail "$3: results differ from the single index"
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert len(a) == len(b) == 41, (len(a), len(b))
results = 0
for x, y in zip(a, b):
    x.pop("stats", None)
    y.pop("stats", None)
    assert x == y, (x.get("id"), json.dumps(x)[:300], json.dumps(y)[:300])
    results += sum(len(p["results"]) for p in x.get("pairs", []))
assert results > 300, results
assert a[-1]["id"] == "broken" and "error" in a[-1]
PY
}
for n in 2 3; do
  for d in shards queries auto; do
    status=0
    mpi 2 "$search" --threads 1 --index "$tmp/c$n.json" --queries "$tmp/q.jsonl" \
      --out "$tmp/r$n$d.jsonl" --distribute "$d" >"$tmp/out.txt" 2>"$tmp/err.txt" || status=$?
    [ "$status" -eq 1 ] || fail "$n shards, $d: exit $status: $(cat "$tmp/err.txt")"
    same "$tmp/r1.jsonl" "$tmp/r$n$d.jsonl" "$n shards over 2 ranks, --distribute $d"
    # Rank 0 alone speaks: one summary line, naming the ranks and the distribution.
    [ "$(grep -c "41 queries (1 failed)" "$tmp/err.txt")" -eq 1 ] || fail "summary: $(cat "$tmp/err.txt")"
    grep -q "2 ranks, distributed by" "$tmp/err.txt" || fail "summary: $(cat "$tmp/err.txt")"
    [ ! -s "$tmp/out.txt" ] || fail "stdout was written besides --out"
  done
done
# Three ranks over two shards: one rank idles under shards, all work under queries.
for d in shards queries; do
  status=0
  mpi 3 "$search" -q --threads 1 --index "$tmp/c2.json" --queries "$tmp/q.jsonl" \
    --out "$tmp/r3r$d.jsonl" --distribute "$d" 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 1 ] || fail "3 ranks, $d: exit $status: $(cat "$tmp/err.txt")"
  same "$tmp/r1.jsonl" "$tmp/r3r$d.jsonl" "2 shards over 3 ranks, --distribute $d"
done
# A plain index: queries (the default), and shards refused.
mpi 2 "$search" -q --threads 1 --index "$tmp/one.h5" --queries "$tmp/q.jsonl" \
  --out "$tmp/rplain.jsonl" || true
same "$tmp/r1.jsonl" "$tmp/rplain.jsonl" "a plain index over 2 ranks"
status=0
mpi 2 "$search" -q --index "$tmp/one.h5" --queries "$tmp/q.jsonl" --distribute shards \
  2>"$tmp/err.txt" || status=$?
[ "$status" -eq 2 ] && grep -q "needs a collection manifest" "$tmp/err.txt" ||
  fail "shards over a plain index: exit $status: $(cat "$tmp/err.txt")"
[ "$(grep -c "needs a collection manifest" "$tmp/err.txt")" -eq 1 ] ||
  fail "the message was printed by more than rank 0: $(cat "$tmp/err.txt")"

# Query filters are checked against the labels of the whole collection, also
# when its shards are dealt to the ranks (each holding only some labels):
# every content of set 1 is valid, a misspelt one lists them all.
python3 - "$set1/data" >"$tmp/labels.jsonl" <<'PY'
import os, sys
frames = '[{"root_position": [0, null, 0]}, {"root_position": [0, null, 1]}]'
for c in sorted({f.split("_")[1] for f in os.listdir(sys.argv[1]) if f.endswith(".bvh")}) + ["wlak"]:
    print('{"id": "%s", "frames": %s, "filter": {"content": "%s"}, "top": 2}' % (c, frames, c))
PY
status=0
"$search" -q --index "$tmp/one.h5" --queries "$tmp/labels.jsonl" --out "$tmp/l1.jsonl" || status=$?
[ "$status" -eq 1 ] || fail "labels, one process: exit $status (expected 1: the misspelt one)"
for n in 2 3; do
  status=0
  mpi 2 "$search" -q --threads 1 --index "$tmp/c$n.json" --queries "$tmp/labels.jsonl" \
    --out "$tmp/l$n.jsonl" --distribute shards 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 1 ] || fail "labels, $n shards: exit $status: $(cat "$tmp/err.txt")"
  python3 - "$tmp/l1.jsonl" "$tmp/l$n.jsonl" <<'PY' || fail "labels over $n shards dealt to 2 ranks"
import json, sys
one, dealt = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
assert len(one) == len(dealt) > 10, (len(one), len(dealt))
for x, y in zip(one[:-1], dealt[:-1]):
    assert "error" not in x and "error" not in y, (x.get("error"), y.get("error"))
    assert x["pairs"] == y["pairs"], x["id"]
e = one[-1]["error"]
assert e.startswith('query wlak: filter.content: unknown value "wlak"; the index has: bow, '), e
assert dealt[-1]["error"] == e.replace("the index has", "the collection has"), dealt[-1]
PY
done

# Style queries (docs/style.md): a style model of the single index; each
# shard's engine reads its clips' styles with it, so asking for a style by
# label or like a file's frames, and the results' recognised styles, are
# those of one process over the single index, under either distribution.
"$indexer" style-model "$tmp/one.h5" --out "$tmp/style.json" >/dev/null
walk="$(cd "$set1/data" && pwd)/dataset-1_walk_normal_001.bvh"
tired="$(cd "$set1/data" && pwd)/dataset-1_walk_tired_001.bvh"
keys='[{"bvh": "'"$walk"'", "frame": 40}, {"bvh": "'"$walk"'", "frame": 70}]'
held='"filter": {"exclude": ["dataset-1_walk_normal_001*"]}'
{
  echo '{"id": "label", "frames": '"$keys"', "style": {"label": "old", "weight": 5}, '"$held"'}'
  echo '{"id": "like", "frames": '"$keys"', "style": {"like": {"bvh": "'"$tired"'", "frames": "10-80"}, "weight": 2}, '"$held"'}'
  echo '{"id": "plain", "frames": '"$keys"', "top": 5}'
} >"$tmp/style.jsonl"
"$search" -q --index "$tmp/one.h5" --style-model "$tmp/style.json" --queries "$tmp/style.jsonl" \
  --out "$tmp/s1.jsonl" || fail "style queries, one process"
for d in shards queries; do
  mpi 2 "$search" -q --threads 1 --index "$tmp/c2.json" --style-model "$tmp/style.json" \
    --queries "$tmp/style.jsonl" --out "$tmp/s2$d.jsonl" --distribute "$d" 2>"$tmp/err.txt" ||
    fail "style queries, 2 shards, $d: $(cat "$tmp/err.txt")"
  python3 - "$tmp/s1.jsonl" "$tmp/s2$d.jsonl" <<'PY' || fail "style queries over 2 shards, $d"
import json, sys
one, two = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
assert [x["id"] for x in one] == [y["id"] for y in two] == ["label", "like", "plain"]
for x, y in zip(one, two):
    x.pop("stats", None)
    y.pop("stats", None)
    assert x == y, (x["id"], json.dumps(x)[:300], json.dumps(y)[:300])
    results = x["pairs"][0]["results"]
    assert results and all("recognised_style" in r for r in results), x["id"]
    assert all(("style_J" in r) == (x["id"] != "plain") for r in results), x["id"]
PY
done

# Failures: exit 2, the rank and the file named, the output left alone.
echo "keep me" >"$tmp/keep.jsonl"
echo "my notes" >"$tmp/notes.txt"
expect_failure() {  # expect_failure WHAT PATTERN mpirun-args...
  local what="$1" pattern="$2"
  shift 2
  status=0
  mpi 2 "$search" "$@" >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 2 ] || fail "$what: exit $status (expected 2): $(cat "$tmp/err.txt")"
  grep -q "$pattern" "$tmp/err.txt" || fail "$what: unclear: $(cat "$tmp/err.txt")"
  [ "$(cat "$tmp/keep.jsonl")" = "keep me" ] && [ "$(cat "$tmp/notes.txt")" = "my notes" ] ||
    fail "$what: an output was replaced"
}
# rank 0 refuses to replace a file that is not a results file: every rank stops.
expect_failure "an output path refused on rank 0" "rank 0: .*notes.txt" \
  -q --index "$tmp/c2.json" --queries "$tmp/q.jsonl" --out "$tmp/notes.txt"
# An output that is a shard of the collection searched: refused even with
# --force, the shard left as it was.
shard_sum="$(md5sum <"$tmp/c3.shard-3-of-3.h5")"
expect_failure "an output that is a shard" "rank 0: .*c3.shard-3-of-3.h5 is the file --index" \
  -q --index "$tmp/c3.json" --queries "$tmp/q.jsonl" --out "$tmp/c3.shard-3-of-3.h5" --force
[ "$(md5sum <"$tmp/c3.shard-3-of-3.h5")" = "$shard_sum" ] || fail "a shard was replaced"
# A rank killed mid-run: the job fails and leaves no temporary results file.
mpirun -np 2 "$search" -q --threads 1 --mode brute --index "$tmp/c3.json" --queries "$tmp/q.jsonl" \
  --out "$tmp/rk.jsonl" >/dev/null 2>&1 &
job=$!
rank1=""
for _ in $(seq 300); do
  for env in /proc/[0-9]*/environ; do
    pid="${env#/proc/}"
    pid="${pid%/environ}"
    if { tr '\0' '\n' <"$env"; } 2>/dev/null | grep -qx "OMPI_COMM_WORLD_RANK=1" &&
      { tr '\0' ' ' <"/proc/$pid/cmdline"; } 2>/dev/null | grep -q "$tmp/rk.jsonl"; then
      rank1="$pid"
    fi
  done
  [ -n "$rank1" ] && break
  sleep 0.1
done
[ -n "$rank1" ] || fail "rank 1 of the job to kill was not found"
kill -9 "$rank1" 2>/dev/null || true
status=0
timeout 300 tail --pid="$job" -f /dev/null || true
wait "$job" || status=$?
[ "$status" -ne 0 ] || echo "note: the job ended before rank 1 was killed"
[ -z "$(find "$tmp" -maxdepth 1 -name '.rk.jsonl.tmp-*')" ] ||
  fail "a killed rank left a temporary results file: $(ls -a "$tmp" | grep tmp-)"
expect_failure "a missing batch" "rank 1: .*nothing.jsonl" \
  -q --index "$tmp/c2.json" --queries "$tmp/nothing.jsonl" --out "$tmp/keep.jsonl" --force
# A shard changed after the manifest was written: the rank holding it names it.
cp "$tmp/c3.shard-3-of-3.h5" "$tmp/saved.h5"
printf 'x' >>"$tmp/c3.shard-3-of-3.h5"
expect_failure "a changed shard" "rank .: .*c3.shard-3-of-3.h5: changed since the manifest" \
  -q --index "$tmp/c3.json" --queries "$tmp/q.jsonl" --out "$tmp/keep.jsonl" --force \
  --distribute shards
mv "$tmp/saved.h5" "$tmp/c3.shard-3-of-3.h5"
rm "$tmp/c2.shard-2-of-2.h5"
expect_failure "a missing shard" "rank .: .*c2.shard-2-of-2.h5: cannot read" \
  -q --index "$tmp/c2.json" --queries "$tmp/q.jsonl" --out "$tmp/keep.jsonl" --force \
  --distribute shards
expect_failure "a missing shard (queries)" "c2.shard-2-of-2.h5" \
  -q --index "$tmp/c2.json" --queries "$tmp/q.jsonl" --out "$tmp/keep.jsonl" --force \
  --distribute queries
echo "PASS"
