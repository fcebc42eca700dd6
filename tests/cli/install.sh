#!/usr/bin/env bash
# cmake --install into a temporary prefix: the programs, the libraries, the
# public headers (exactly the LIBRARY/include trees) and the CMake package are
# there; a project of its own (tests/install/consumer, the program docs/api.md
# shows) configures with find_package(mocap) against the installed tree only,
# builds, and finds the same best partial motion as the installed
# mocap-search on a small set-1 index.
#   bash tests/cli/install.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup install "$@"
src="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
prefix="$tmp/prefix"
cmake --install "$build" --prefix "$prefix" >"$tmp/install.log" 2>&1 ||
  { cat "$tmp/install.log" >&2; fail "cmake --install failed"; }

for p in mocap-index mocap-search mocap-synth mocap-synth-quality; do
  [ -x "$prefix/bin/$p" ] || fail "bin/$p not installed"
  "$prefix/bin/$p" --help >/dev/null || fail "the installed $p does not run"
done
libdir="$(find "$prefix" -name libmocap_common.a -printf '%h\n')"
[ -n "$libdir" ] || fail "libmocap_common.a not installed"
for l in common player indexer search synth; do
  [ -f "$libdir/libmocap_$l.a" ] || fail "libmocap_$l.a not installed"
done
for f in mocapConfig.cmake mocapConfigVersion.cmake mocapTargets.cmake; do
  [ -f "$libdir/cmake/mocap/$f" ] || fail "lib/cmake/mocap/$f not installed"
done
# Headers: every public header, and nothing else (no private src/ header).
(cd "$prefix/include" && find mocap -type f | sort) >"$tmp/installed-headers"
(cd "$src" && for l in common common/player indexer search synth; do (cd "$l/include" && find mocap -name '*.hpp'); done | sort) \
  >"$tmp/public-headers"
diff "$tmp/public-headers" "$tmp/installed-headers" >&2 || fail "installed headers differ from the public ones"

# docs/api.md shows the consumer's program as it is.
python3 - "$src/docs/api.md" "$src/tests/install/consumer/main.cpp" <<'PY' || fail "docs/api.md does not show tests/install/consumer/main.cpp"
import sys
doc, main = open(sys.argv[1]).read(), open(sys.argv[2]).read()
section = doc.split("## Searching an index from C++", 1)[1]
assert section.split("```cpp\n", 1)[1].split("```", 1)[0] == main
PY

# The consumer: configured against the prefix alone (the build's compiler).
cxx="$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")"
cmake -S "$src/tests/install/consumer" -B "$tmp/consumer" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" ${cxx:+-DCMAKE_CXX_COMPILER="$cxx"} -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
  >"$tmp/consumer.log" 2>&1 || { cat "$tmp/consumer.log" >&2; fail "the consumer did not configure"; }
grep -q "$src/[a-z]*/include" "$tmp/consumer/compile_commands.json" &&
  fail "the consumer compiles against the source tree, not the installed one"
cmake --build "$tmp/consumer" >>"$tmp/consumer.log" 2>&1 ||
  { cat "$tmp/consumer.log" >&2; fail "the consumer did not build"; }

# Query frames of one walk, searched among other clips (a non-zero score).
d="$data/bandai-namco-1/data"
"$prefix/bin/mocap-index" build -q --out "$tmp/i.h5" "$d/dataset-1_walk_normal_002.bvh" \
  "$d/dataset-1_walk_musical_001.bvh" "$d/dataset-1_bow_active_001.bvh" >/dev/null 2>&1
w="$d/dataset-1_walk_normal_001.bvh"
echo "{\"id\": \"walk\", \"relative\": false, \"frames\": [{\"bvh\": \"$w\", \"frame\": 10}, {\"bvh\": \"$w\", \"frame\": 40}]}" \
  >"$tmp/q.json"
"$tmp/consumer/best_match" "$tmp/i.h5" "$tmp/q.json" >"$tmp/got.txt"
"$prefix/bin/mocap-search" --index "$tmp/i.h5" --query "$tmp/q.json" -q --out "$tmp/r.jsonl"
python3 - "$tmp/r.jsonl" >"$tmp/want.txt" <<'PY'
import json, sys
best = json.loads(open(sys.argv[1]).readline())["pairs"][0]["results"][0]
print(f'{best["clip"]} {best["start_frame"]}-{best["end_frame"]} {best["score_J"]:.6f} J')
PY
diff "$tmp/want.txt" "$tmp/got.txt" >&2 || fail "the consumer's best match is not mocap-search's"
grep -q " 0.000000 J$" "$tmp/got.txt" && fail "a zero score: the query's clip is in the index"
# Errors reach the caller as the library reports them (file and reason).
rc=0
"$tmp/consumer/best_match" "$tmp/missing.h5" "$tmp/q.json" 2>"$tmp/err.txt" || rc=$?
[ "$rc" = 2 ] && grep -q "missing.h5" "$tmp/err.txt" || fail "a missing index: exit $rc, $(cat "$tmp/err.txt")"
echo "install ok: $(cat "$tmp/got.txt")"
