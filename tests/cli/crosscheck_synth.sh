#!/usr/bin/env bash
# An output of mocap-synth loads identically in Blender and three.js: world
# joint positions of sampled frames agree with our forward kinematics
# (mocap-index inspect) to 1e-4 m (tests/crosscheck/compare.py).
#   bash tests/cli/crosscheck_synth.sh BUILD_DIR DATA_DIR
set -euo pipefail
build="${1:?usage: crosscheck_synth.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: crosscheck_synth.sh BUILD_DIR DATA_DIR}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
skip() { missing_tool scripts/crosscheck-setup "$@"; }
[ -x "$build/synth/mocap-synth" ] || { echo "FAIL: mocap-synth not built" >&2; exit 1; }
[ -d "$data/bandai-namco-1/data" ] || { echo "SKIP: no data at $data"; exit 77; }
command -v "${BLENDER:-blender}" >/dev/null 2>&1 || skip "blender not found"
command -v "${NODE:-node}" >/dev/null 2>&1 || skip "node not found"
[ -f "$root/tests/crosscheck/node_modules/three/examples/jsm/loaders/BVHLoader.js" ] || skip "three.js not installed"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$build/indexer/mocap-index" build --out "$tmp/index.h5" "$data/bandai-namco-1" "$data/cmu" >/dev/null 2>&1
python3 "$root/tests/synth/synth_fixture.py" --index-data "$data" --out "$tmp" >/dev/null
"$build/synth/mocap-synth" --index "$tmp/index.h5" --query "$tmp/query.json" --results "$tmp/results.jsonl" \
  --out "$tmp/synth-motion.bvh" >/dev/null
python3 "$root/tests/crosscheck/compare.py" --bin "$build/indexer/mocap-index" --ref blender --ref three \
  --unit cm --random 6 "$tmp/synth-motion.bvh"
