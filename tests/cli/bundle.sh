#!/usr/bin/env bash
# scripts/bundle (docs/cli.md "A bundle for other machines"): the tarball
# holds the three executables and their libraries but glibc's; unpacked
# elsewhere and run with an empty environment (no LD_LIBRARY_PATH) it loads
# nothing from the build tree or from the system but glibc, reports its
# version, builds an index of a few set-1 clips and answers a query exactly as
# the build tree's executables do (the same results line but for the time);
# an OUT that is not a gzip file is refused and kept; a missing build is a
# clear error.
#   bash tests/cli/bundle.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup bundle "$@"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
command -v patchelf >/dev/null || missing_tool scripts/setup "patchelf not found"
bundle="$root/scripts/bundle"

# Refusals first.
echo "keep me" >"$tmp/notes.tar.gz"
rc=0
"$bundle" --build "$build" "$tmp/notes.tar.gz" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] || fail "a non-gzip OUT: exit $rc (expected 2)"
grep -q "not a gzip file" "$tmp/err.txt" || fail "unclear: $(cat "$tmp/err.txt")"
[ "$(cat "$tmp/notes.tar.gz")" = "keep me" ] || fail "the file at OUT was changed"
rc=0
"$bundle" --build "$tmp/no-build" "$tmp/b.tar.gz" >/dev/null 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "no-build/indexer/mocap-index not found" "$tmp/err.txt" ||
  fail "a missing build: exit $rc, $(cat "$tmp/err.txt")"
[ ! -e "$tmp/b.tar.gz" ] || fail "a bundle was written without a build"

"$bundle" --build "$build" "$tmp/b.tar.gz" >/dev/null
mkdir "$tmp/node"
tar -C "$tmp/node" -xzf "$tmp/b.tar.gz"
bin="$tmp/node/mocap/bin"
for e in mocap-index mocap-search mocap-synth; do
  [ -x "$bin/$e" ] || fail "no $e in the bundle"
  # Every library but glibc's and the loader comes from the bundle.
  env -i ldd "$bin/$e" >"$tmp/ldd.txt"
  ! grep -q "not found" "$tmp/ldd.txt" || fail "$e: $(grep "not found" "$tmp/ldd.txt")"
  ! grep -q "$build" "$tmp/ldd.txt" || fail "$e loads from the build tree"
  lib="$(cd "$tmp/node/mocap/lib" && pwd -P)"
  outside="$(awk '$2 == "=>" {print $3}' "$tmp/ldd.txt" | xargs -r -n1 readlink -f | grep -v "^$lib/" |
    grep -Ev '/(libc|libm|libdl|libpthread|librt|libresolv|libutil|libmvec)\.so' || true)"
  [ -z "$outside" ] || fail "$e loads from outside the bundle: $outside"
  case "$e" in mocap-index) own="$indexer" ;; mocap-search) own="$search" ;; *) own="$synth" ;; esac
  [ "$(env -i "$bin/$e" --version)" = "$("$own" --version)" ] ||
    fail "$e --version differs from the build's"
done
grep -q "libtbb" "$tmp/node/mocap/MANIFEST" || fail "MANIFEST lists no TBB"

# A small index and a query, from an empty environment, as the build answers it.
mkdir "$tmp/clips"
for c in walk_normal_001 walk_happy_001 bye_normal_001; do
  ln -s "$(cd "$data/bandai-namco-1/data" && pwd)/dataset-1_$c.bvh" "$tmp/clips/"
done
env -i "$bin/mocap-index" build -q --out "$tmp/node.h5" "$tmp/clips" >/dev/null
"$indexer" build -q --out "$tmp/here.h5" "$tmp/clips" >/dev/null
w="$tmp/clips/dataset-1_walk_normal_001.bvh"
echo "{\"id\": \"w\", \"frames\": [{\"bvh\": \"$w\", \"frame\": 10}, {\"bvh\": \"$w\", \"frame\": 40}], \"top\": 3}" >"$tmp/q.jsonl"
env -i "$bin/mocap-search" -q --index "$tmp/node.h5" --queries "$tmp/q.jsonl" --out "$tmp/node.jsonl"
"$search" -q --index "$tmp/here.h5" --queries "$tmp/q.jsonl" --out "$tmp/here.jsonl"
/usr/bin/python3 - "$tmp/node.jsonl" "$tmp/here.jsonl" <<'PY' || fail "the bundle's search differs"
import json, sys
a, b = (json.loads(open(p).readline()) for p in sys.argv[1:])
for x in (a, b):
    x.pop("stats")
assert a == b and a["pairs"][0]["results"], (a, b)
PY
echo "OK"
