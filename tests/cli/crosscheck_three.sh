#!/usr/bin/env bash
# Cross-check: our forward kinematics (mocap-index inspect --json) against
# three.js BVHLoader under node (tests/crosscheck/three_fk.mjs) on the CMU
# files; world joint positions must agree to 1e-4 m on sampled frames.
# three.js adds position channels to OFFSET (we replace it), so it is used only
# on files whose position channels sit on joints with OFFSET 0 0 0 (CMU: root
# only). See docs/crosscheck.md.
#   bash tests/cli/crosscheck_three.sh BUILD_DIR DATA_DIR
# Exit 77 (skipped) when node, three.js (tests/crosscheck/node_modules) or the
# data is missing, except that under CI=true missing tools fail.
set -euo pipefail
build="${1:?usage: crosscheck_three.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: crosscheck_three.sh BUILD_DIR DATA_DIR}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="$build/indexer/mocap-index"

source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
skip() { missing_tool scripts/crosscheck-setup "$@"; }

[ -x "$bin" ] || { echo "FAIL: $bin not built" >&2; exit 1; }
command -v python3 >/dev/null 2>&1 || skip "python3 not found"
command -v "${NODE:-node}" >/dev/null 2>&1 || skip "node not found"
[ -f "$root/tests/crosscheck/node_modules/three/examples/jsm/loaders/BVHLoader.js" ] ||
  skip "three.js not installed in tests/crosscheck/node_modules"

files=("$data/cmu/131_01.bvh" "$data/cmu/131_02.bvh" "$data/cmu/131_03.bvh")
for f in "${files[@]}"; do
  [ -f "$f" ] || { echo "SKIP: data file $f missing"; exit 77; }
done

python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref three --unit cmu --random 8 "${files[@]}"
