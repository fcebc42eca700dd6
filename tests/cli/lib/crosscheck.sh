# Sourced by the cross-check tests (tests/cli/crosscheck_*.sh), which compare
# our forward kinematics with Blender's and three.js's BVH importers
# (tests/crosscheck, docs/crosscheck.md). Their shared set-up:
#
#   source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
#
# takes the test's arguments BUILD_DIR DATA_DIR and sets build, data, root
# (the repository) and bin (mocap-index, which must be built), and defines
#   skip MESSAGE          a tool is missing: skip, or fail under CI=true
#                         (missing_tool, lib/common.sh)
#   need_python           python3 (tests/crosscheck/compare.py)
#   need_blender          Blender ($BLENDER, default blender)
#   need_three            node ($NODE, default node) and three.js installed in
#                         tests/crosscheck/node_modules
#   need_files FILE...    data files: skip (exit 77) when one is missing
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

_crosscheck_usage="usage: $(basename "$0") BUILD_DIR DATA_DIR"
build="${1:?$_crosscheck_usage}"
data="${2:?$_crosscheck_usage}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)"
bin="$build/indexer/mocap-index"

skip() { missing_tool scripts/crosscheck-setup "$@"; }

need_python() {
  command -v python3 >/dev/null 2>&1 || skip "python3 not found"
}
need_blender() {
  command -v "${BLENDER:-blender}" >/dev/null 2>&1 || skip "blender not found"
}
need_three() {
  command -v "${NODE:-node}" >/dev/null 2>&1 || skip "node not found"
  [ -f "$root/tests/crosscheck/node_modules/three/examples/jsm/loaders/BVHLoader.js" ] ||
    skip "three.js not installed in tests/crosscheck/node_modules"
}
need_files() {
  local f
  for f in "$@"; do
    [ -f "$f" ] || { echo "SKIP: data file $f missing"; exit 77; }
  done
}

[ -x "$bin" ] || { echo "FAIL: $bin not built" >&2; exit 1; }
