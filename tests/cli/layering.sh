#!/usr/bin/env bash
# The dependency picture of docs/architecture.md, checked two ways:
#  1. includes: no file of a lower layer includes a header of a higher one
#     (common/ includes no mocap/player, search, synth or indexer header;
#     common/player/ no search, synth or indexer header; indexer/ and search/
#     (its executable and MPI part included) no synth header and not each
#     other's; synth/ no indexer header);
#  2. links: CMake's target graph (cmake --graphviz of a fresh configure)
#     has no path from a lower library or executable to a higher one.
#   bash tests/cli/layering.sh BUILD_DIR DATA_DIR   (neither is read: the
#   source tree is the script's, the configure is made in a temporary folder)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# forbid FOLDER PATTERN WHAT: no C++ file under FOLDER (but EXCEPT) includes PATTERN.
forbid() {
  local folder="$1" pattern="$2" what="$3" except="${4:-}" hits
  hits="$(grep -rnE --include='*.cpp' --include='*.hpp' "^#include \"mocap/($pattern)/" \
    "$root/$folder" | { [ -n "$except" ] && grep -v "^$root/$except/" || cat; } || true)"
  [ -z "$hits" ] || { echo "$hits" >&2; fail "$folder includes $what headers"; }
}
forbid common 'player|search|synth|indexer' 'player, search, synth or indexer' common/player
forbid common/player 'search|synth|indexer' 'search, synth or indexer'
forbid indexer 'player|search|synth' 'player, search or synth'
forbid search 'synth|indexer' 'synth or indexer'
forbid synth 'indexer' 'indexer'
# The check itself: a search file that includes a synth header is caught.
mkdir -p "$tmp/tree/search"
echo '#include "mocap/synth/synth.hpp"' >"$tmp/tree/search/bad.cpp"
if (root="$tmp/tree" forbid search 'synth|indexer' 'synth' 2>/dev/null); then
  fail "the include check misses a synth header in search/"
fi

# Links: configure the tree afresh (no tests, benchmarks or Python: the
# libraries and executables only) and read the target graph.
cmake -S "$root" -B "$tmp/build" -G Ninja -DMOCAP_TESTS=OFF -DMOCAP_BENCH=OFF \
  -DMOCAP_PYTHON=OFF --graphviz="$tmp/targets.dot" >"$tmp/configure.log" 2>&1 ||
  { tail -20 "$tmp/configure.log" >&2; fail "cmake configure failed"; }
python3 - "$tmp/targets.dot" <<'PY' || fail "the target graph has an arrow running back up"
import re, sys
text = open(sys.argv[1]).read()
names = dict(re.findall(r'"(node\d+)"\s*\[\s*label\s*=\s*"([^"]+)"', text))
edges = {}
for a, b in re.findall(r'"(node\d+)"\s*->\s*"(node\d+)"', text):
    edges.setdefault(names[a], set()).add(names[b])
def reach(t, seen=None):
    seen = set() if seen is None else seen
    for n in edges.get(t, ()):
        if n not in seen:
            seen.add(n)
            reach(n, seen)
    return seen
for t in ("mocap_common", "mocap_player", "mocap_indexer", "mocap_search", "mocap-search",
          "mocap-index", "mocap_search_mpi", "mocap_synth"):
    if t not in names.values() and t != "mocap_search_mpi":
        sys.exit(f"target {t} missing from the graph")
rules = {  # target: what it may never reach
    "mocap_common": {"mocap_player", "mocap_indexer", "mocap_search", "mocap_synth"},
    "mocap_player": {"mocap_indexer", "mocap_search", "mocap_synth"},
    "mocap_indexer": {"mocap_player", "mocap_search", "mocap_synth"},
    "mocap-index": {"mocap_player", "mocap_search", "mocap_synth"},
    "mocap_search": {"mocap_indexer", "mocap_synth"},
    "mocap_search_mpi": {"mocap_indexer", "mocap_synth"},
    "mocap-search": {"mocap_indexer", "mocap_synth"},
    "mocap_synth": {"mocap_indexer"},
}
bad = [f"{t} -> {sorted(reach(t) & never)}" for t, never in rules.items() if reach(t) & never]
if bad:
    sys.exit("\n".join(bad))
print("layering: ok (" + ", ".join(f"{t}: {len(reach(t))} dependencies" for t in rules
                                   if t in names.values()) + ")")
PY
