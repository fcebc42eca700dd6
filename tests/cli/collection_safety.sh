#!/usr/bin/env bash
# A collection is as safe as one index (docs/cli.md "Output paths" and
# "Collections"): no output of export, mocap-synth, mocap-search (--out,
# --html) or view replaces a shard of the collection it reads, even with
# --force; a tampered manifest (a shard listed twice or 1,000 times,
# reordered, dropped, wrong clip counts, 5,000 entries, a NUL in a path) is
# refused alike by verify, info and search, and an upper-case xxh64 is
# accepted; build --shards writes through a symbolic link at --out, locks the
# manifest whatever the shard count, checks every shard path before building
# any, and removes a killed build's stale temporary shard files; the
# progress over a collection counts queries, not queries x shards.
#   bash tests/cli/collection_safety.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup collection_safety "$@"
bn="$(cd "$data/bandai-namco-1/data" && pwd)"
walk="$bn/dataset-1_walk_normal_001.bvh"
mkdir "$tmp/in"
cp "$walk" "$bn/dataset-1_walk_normal_002.bvh" "$bn/dataset-1_run_normal_001.bvh" \
  "$bn/dataset-1_bye_normal_001.bvh" "$tmp/in/"
"$indexer" build -q --shards 3 --out "$tmp/col.json" "$tmp/in" >/dev/null || fail "build --shards 3 failed"
"$indexer" verify "$tmp/col.json" >/dev/null || fail "verify of the fresh collection failed"
sums() { md5sum "$tmp"/col.shard-*-of-3.h5 "$tmp/col.json"; }
before="$(sums)"

{
  printf '{"id": "a", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 2}\n' "$walk" "$walk"
  printf '{"id": "b", "frames": [{"bvh": "%s", "frame": 20}, {"bvh": "%s", "frame": 60}], "top": 2}\n' "$walk" "$walk"
} >"$tmp/q.jsonl"
printf '{"id": "walk", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
  "$walk" "$walk" >"$tmp/s.json"
"$search" -q --index "$tmp/col.json" --queries "$tmp/q.jsonl" --out "$tmp/r.jsonl" ||
  fail "search over the collection failed"

# refused_output WHAT CMD...: CMD fails (exit != 0), says its output is a
# file it reads, and every shard and the manifest are as they were.
refused_output() {
  local what="$1" status=0
  shift
  "$@" >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -ne 0 ] || fail "$what: an output replaced a shard (exit 0)"
  grep -q "reads" "$tmp/err.txt" || fail "$what: unclear: $(cat "$tmp/err.txt")"
  [ "$(sums)" = "$before" ] || fail "$what: a shard or the manifest changed"
}
refused_output "export --out SHARD --force" "$search" export --index "$tmp/col.json" \
  --clip dataset-1_walk_normal_001.bvh --frames 0-5 --out "$tmp/col.shard-1-of-3.h5" --force
refused_output "mocap-synth --out SHARD --force" "$synth" --index "$tmp/col.json" \
  --query "$tmp/s.json" --out "$tmp/col.shard-2-of-3.h5" --force
refused_output "mocap-synth --report SHARD --force" "$synth" --index "$tmp/col.json" \
  --query "$tmp/s.json" --out "$tmp/m.bvh" --report "$tmp/col.shard-1-of-3.h5" --force
refused_output "mocap-search --out SHARD --force" "$search" -q --index "$tmp/col.json" \
  --queries "$tmp/q.jsonl" --out "$tmp/col.shard-3-of-3.h5" --force
refused_output "mocap-search --html SHARD --force" "$search" -q --index "$tmp/col.json" \
  --queries "$tmp/q.jsonl" --html "$tmp/col.shard-3-of-3.h5" --force
refused_output "view --out SHARD --force" "$search" view --index "$tmp/col.json" \
  --results "$tmp/r.jsonl" --out "$tmp/col.shard-2-of-3.h5" --force
# Through a link to a shard, too.
ln -s col.shard-1-of-3.h5 "$tmp/alias.h5"
refused_output "mocap-search --out LINK-TO-SHARD --force" "$search" -q --index "$tmp/col.json" \
  --queries "$tmp/q.jsonl" --out "$tmp/alias.h5" --force
"$indexer" verify "$tmp/col.json" >/dev/null || fail "the collection no longer verifies"

# Progress over 3 shards counts the 2 queries (not 6).
"$search" --index "$tmp/col.json" --queries "$tmp/q.jsonl" --out "$tmp/r2.jsonl" 2>"$tmp/err.txt" ||
  fail "search failed: $(cat "$tmp/err.txt")"
grep -q "mocap-search: 2/2 queries" "$tmp/err.txt" || fail "progress: $(cat "$tmp/err.txt")"
if grep -q "/6 queries" "$tmp/err.txt"; then fail "progress counts queries x shards"; fi

# tampered NAME PYTHON: writes $tmp/NAME.json from the manifest (m) by PYTHON.
tampered() {
  python3 - "$tmp/col.json" "$tmp/$1.json" "$2" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
s = m["shards"]
exec(sys.argv[3])
json.dump(m, open(sys.argv[2], "w"), indent=2)
PY
}
# refused_manifest NAME PATTERN: verify (exit 1 or 2), info and search
# (exit 2) refuse $tmp/NAME.json, each saying PATTERN.
refused_manifest() {
  local status=0
  timeout 60 "$indexer" verify "$tmp/$1.json" >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 1 ] || [ "$status" -eq 2 ] || fail "verify of $1: exit $status"
  grep -q "$2" "$tmp/err.txt" || fail "verify of $1: unclear: $(cat "$tmp/err.txt")"
  status=0
  timeout 60 "$indexer" info "$tmp/$1.json" >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 2 ] || fail "info of $1: exit $status"
  grep -q "$2" "$tmp/err.txt" || fail "info of $1: unclear: $(cat "$tmp/err.txt")"
  status=0
  timeout 60 "$search" -q --index "$tmp/$1.json" --queries "$tmp/q.jsonl" >/dev/null 2>"$tmp/err.txt" ||
    status=$?
  [ "$status" -eq 2 ] || fail "search over $1: exit $status"
  grep -q "$2" "$tmp/err.txt" || fail "search over $1: unclear: $(cat "$tmp/err.txt")"
}
tampered twice 's.insert(1, dict(s[0]))'
refused_manifest twice "reordered, repeated or missing"
tampered thousand 'm["shards"] = [dict(s[0]) for _ in range(1000)]'
refused_manifest thousand "reordered, repeated or missing"
tampered reordered 's[0], s[1] = s[1], s[0]'
refused_manifest reordered "reordered, repeated or missing"
tampered dropped 'del s[1]'
refused_manifest dropped "reordered, repeated or missing"
# Shards under names of their own: a file listed twice is still refused.
cp "$tmp/col.shard-1-of-3.h5" "$tmp/first.h5"
tampered renamed 's[0]["path"] = "first.h5"; s.insert(1, dict(s[0]))'
refused_manifest renamed "first.h5 is the file of shards\[0\] again"
tampered clips 's[0]["clips"] += 1'
refused_manifest clips "clips, the manifest says"
tampered huge 's[0]["clips"] = 2**64 - 1'
refused_manifest huge "2^64\|clips, the manifest says"
tampered frames 's[2]["frames"] -= 1'
refused_manifest frames "frames, the manifest says"
tampered nul 's[0]["path"] = s[0]["path"][:3] + "\0" + s[0]["path"][3:]'
refused_manifest nul "NUL"
tampered many 'm["shards"] = [dict(s[0], path="x%d.h5" % i) for i in range(5000)]'
refused_manifest many "more than the limit of 4096"
# An upper-case xxh64 is the same hash.
tampered upper 'for x in s: x["xxh64"] = x["xxh64"].upper()'
"$indexer" verify "$tmp/upper.json" >/dev/null 2>"$tmp/err.txt" ||
  fail "an upper-case xxh64 was refused: $(cat "$tmp/err.txt")"

# build --shards through a symbolic link: the link stays a link, the
# manifest and its shards are written beside the file it leads to.
mkdir "$tmp/real"
echo '{}' >"$tmp/real/lc.json"
ln -s real/lc.json "$tmp/lc.json"
"$indexer" build -q --force --shards 2 --out "$tmp/lc.json" "$tmp/in" >/dev/null 2>"$tmp/err.txt" ||
  fail "build --shards through a link failed: $(cat "$tmp/err.txt")"
[ -L "$tmp/lc.json" ] || fail "the link at --out was replaced by a file"
[ -f "$tmp/real/lc.shard-1-of-2.h5" ] || fail "the shards are not beside the link's file"
"$indexer" verify "$tmp/lc.json" >/dev/null || fail "verify through the link failed"
"$indexer" verify "$tmp/real/lc.json" >/dev/null || fail "verify of the link's file failed"

# One build per manifest, whatever the shard count: while its lock is held
# a build with another count fails at once and writes nothing.
if command -v flock >/dev/null; then
  status=0
  flock "$tmp/.col.json.lock" "$indexer" build -q --shards 2 --out "$tmp/col.json" "$tmp/in" \
    >/dev/null 2>"$tmp/err.txt" || status=$?
  [ "$status" -eq 2 ] || fail "a build with another shard count ran under the lock (exit $status)"
  grep -q "another process is writing" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
  [ ! -e "$tmp/col.shard-1-of-2.h5" ] || fail "a shard was written under the lock"
  [ "$(sums)" = "$before" ] || fail "the collection changed under the lock"
fi

# Every shard path is checked before any shard is built.
mkfifo "$tmp/ff.shard-2-of-2.h5"
status=0
timeout 60 "$indexer" build -q --shards 2 --out "$tmp/ff.json" "$tmp/in" >/dev/null 2>"$tmp/err.txt" ||
  status=$?
[ "$status" -eq 2 ] || fail "a FIFO at shard 2: exit $status (expected 2)"
grep -q "FIFO" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ ! -e "$tmp/ff.shard-1-of-2.h5" ] || fail "shard 1 was built before shard 2's path was refused"
[ ! -e "$tmp/ff.json" ] || fail "a manifest was written"

# A stale temporary shard file of a killed build (its PID no longer runs) is
# removed by the next build, even when that shard is up to date.
dead="$(sh -c 'echo $$')"
while kill -0 "$dead" 2>/dev/null; do dead=$((dead + 1)); done
touch "$tmp/.col.shard-2-of-3.h5.tmp-$dead"
"$indexer" build -q --shards 3 --out "$tmp/col.json" "$tmp/in" >/dev/null || fail "rebuild failed"
[ ! -e "$tmp/.col.shard-2-of-3.h5.tmp-$dead" ] || fail "a stale temporary shard file survived"
[ "$(sums)" = "$before" ] || fail "an up-to-date rebuild changed the collection"
echo "PASS"
