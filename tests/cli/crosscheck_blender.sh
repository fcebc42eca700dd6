#!/usr/bin/env bash
# Cross-check: our forward kinematics (mocap-index inspect --json) against
# Blender's BVH importer run headless (tests/crosscheck/blender_fk.py), on
# Bandai Namco set-1 and CMU files; world joint positions must agree to 1e-4 m
# on sampled frames. See docs/crosscheck.md.
#   bash tests/cli/crosscheck_blender.sh BUILD_DIR DATA_DIR
# Exit 77 (skipped) when Blender or the data is missing, except that under
# CI=true a missing Blender fails: CI must run the cross-check.
set -euo pipefail
build="${1:?usage: crosscheck_blender.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: crosscheck_blender.sh BUILD_DIR DATA_DIR}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bin="$build/indexer/mocap-index"

source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
skip() { missing_tool scripts/crosscheck-setup "$@"; }

[ -x "$bin" ] || { echo "FAIL: $bin not built" >&2; exit 1; }
command -v python3 >/dev/null 2>&1 || skip "python3 not found"
command -v "${BLENDER:-blender}" >/dev/null 2>&1 || skip "blender not found"

bn="$data/bandai-namco-1/data"
bn_files=("$bn/dataset-1_bow_active_001.bvh" "$bn/dataset-1_run_happy_001.bvh")
cmu_files=("$data/cmu/131_01.bvh" "$data/cmu/131_03.bvh")
for f in "${bn_files[@]}" "${cmu_files[@]}"; do
  [ -f "$f" ] || { echo "SKIP: data file $f missing"; exit 77; }
done

status=0
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cm --random 8 \
  "${bn_files[@]}" || status=1
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cmu --random 8 \
  "${cmu_files[@]}" || status=1
exit $status
