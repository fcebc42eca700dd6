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
source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
need_python
need_three

files=("$data/cmu/131_01.bvh" "$data/cmu/131_02.bvh" "$data/cmu/131_03.bvh")
need_files "${files[@]}"

python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref three --unit cmu --random 8 "${files[@]}"
