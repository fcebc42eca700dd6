#!/usr/bin/env bash
# Output paths (docs/cli.md "Output paths"): no tool replaces what it should
# not. For mocap-index build, mocap-search and mocap-synth: a FIFO, a folder
# or a file of another kind at --out is refused (non-zero exit) and left as
# it was; --force replaces a file of another kind; a symbolic link is written
# through (it stays a link, its file gets the output); mocap-synth refuses
# --report naming the --out file; mocap-search --out is replaced only once
# every query is answered.
#   bash tests/cli/output_paths.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup output_paths "$@"
bn="$(cd "$data/bandai-namco-1/data" && pwd)"
mkdir "$tmp/in"
cp "$bn/dataset-1_walk_normal_001.bvh" "$bn/dataset-1_walk_normal_002.bvh" \
  "$bn/dataset-1_run_normal_001.bvh" "$tmp/in/"

# refused CMD... : the command must fail and say why on stderr.
refused() {
  if "$@" >"$tmp/out.txt" 2>"$tmp/err.txt"; then fail "accepted: $*"; fi
  [ -s "$tmp/err.txt" ] || fail "no message for: $*"
}

# mocap-index build
mkfifo "$tmp/fifo.h5"
refused "$indexer" build -q --out "$tmp/fifo.h5" "$tmp/in"
[ -p "$tmp/fifo.h5" ] || fail "the FIFO was replaced"
mkdir "$tmp/dir.h5"
refused "$indexer" build -q --out "$tmp/dir.h5" "$tmp/in"
[ -d "$tmp/dir.h5" ] || fail "the folder was replaced"
printf '{"id": "keep me"}\n' >"$tmp/notes.jsonl"
refused "$indexer" build -q --out "$tmp/notes.jsonl" "$tmp/in"
grep -q "keep me" "$tmp/notes.jsonl" || fail "a JSON lines file was replaced by the index"
grep -q "is not an index" "$tmp/err.txt" || fail "the message does not say why: $(cat "$tmp/err.txt")"
"$indexer" build -q --force --out "$tmp/notes.jsonl" "$tmp/in" >/dev/null 2>&1 ||
  fail "--force did not replace a file of another kind"
"$indexer" verify "$tmp/notes.jsonl" >/dev/null 2>&1 || fail "--force did not write an index"
"$indexer" build -q --out "$tmp/real.h5" "$tmp/in" >/dev/null 2>&1 || fail "plain build failed"
ln -s real.h5 "$tmp/link.h5"
rm "$tmp/in/dataset-1_run_normal_001.bvh"
"$indexer" build -q --out "$tmp/link.h5" "$tmp/in" >/dev/null 2>&1 || fail "build through a link failed"
[ -L "$tmp/link.h5" ] || fail "the symbolic link was replaced by a file"
"$indexer" info "$tmp/real.h5" --json | grep -q '"clips": *2,' || fail "the link's file did not get the new index"

# mocap-search
q="$tmp/q.jsonl"
printf '{"id": "a", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
  "$bn/dataset-1_walk_normal_001.bvh" "$bn/dataset-1_walk_normal_001.bvh" >"$q"
refused "$search" -q --index "$tmp/real.h5" --queries "$q" --out "$tmp/fifo.h5"
[ -p "$tmp/fifo.h5" ] || fail "mocap-search replaced the FIFO"
printf 'HIERARCHY\nROOT x\n' >"$tmp/motion.bvh"
refused "$search" -q --index "$tmp/real.h5" --queries "$q" --out "$tmp/motion.bvh"
grep -q HIERARCHY "$tmp/motion.bvh" || fail "mocap-search replaced a BVH file"
refused "$search" -q --index "$tmp/real.h5" --queries "$q" --out "$q"
grep -q '"id": "a"' "$q" || fail "mocap-search replaced its own query file"
printf '{"id": "old"}\n' >"$tmp/r.jsonl"
"$search" -q --index "$tmp/real.h5" --queries "$q" --out "$tmp/r.jsonl" || fail "search failed"
grep -q '"pairs"' "$tmp/r.jsonl" || fail "mocap-search did not replace an earlier results file"
printf '{"id": "old"}\n' >"$tmp/r2.jsonl"
refused "$search" -q --index "$tmp/missing.h5" --queries "$q" --out "$tmp/r2.jsonl"
grep -q '"old"' "$tmp/r2.jsonl" || fail "a failed search truncated --out"

# mocap-synth
sq="$tmp/sq.json"
printf '{"id": "s", "frames": [{"bvh": "%s", "frame": 10}, {"bvh": "%s", "frame": 40}], "top": 1}\n' \
  "$bn/dataset-1_walk_normal_001.bvh" "$bn/dataset-1_walk_normal_001.bvh" >"$sq"
refused "$synth" --index "$tmp/real.h5" --query "$sq" --out "$tmp/m.bvh" --report "$tmp/m.bvh"
[ ! -e "$tmp/m.bvh" ] || fail "mocap-synth wrote although --report is --out"
printf '{"id": "keep"}\n' >"$tmp/notes2.jsonl"
refused "$synth" --index "$tmp/real.h5" --query "$sq" --out "$tmp/notes2.jsonl"
grep -q keep "$tmp/notes2.jsonl" || fail "mocap-synth replaced a JSON lines file with BVH"
refused "$synth" --index "$tmp/real.h5" --query "$sq" --out "$tmp/fifo.h5"
[ -p "$tmp/fifo.h5" ] || fail "mocap-synth replaced the FIFO"
"$synth" --index "$tmp/real.h5" --query "$sq" --out "$tmp/m.bvh" --report "$tmp/m.json" \
  --html "$tmp/m.html" >/dev/null || fail "synth failed"
"$synth" --index "$tmp/real.h5" --query "$sq" --out "$tmp/m.bvh" --report "$tmp/m.json" \
  --html "$tmp/m.html" >/dev/null || fail "synth did not replace its own earlier outputs"
echo "PASS"
