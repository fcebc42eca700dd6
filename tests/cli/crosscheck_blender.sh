#!/usr/bin/env bash
# Cross-check: our forward kinematics (mocap-index inspect --json) against
# Blender's BVH importer run headless (tests/crosscheck/blender_fk.py), on
# Bandai Namco set-1 and CMU files; world joint positions must agree to 1e-4 m
# on sampled frames. See docs/crosscheck.md.
#   bash tests/cli/crosscheck_blender.sh BUILD_DIR DATA_DIR
# Exit 77 (skipped) when Blender or the data is missing, except that under
# CI=true a missing Blender fails: CI must run the cross-check.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
need_python
need_blender

bn="$data/bandai-namco-1/data"
bn_files=("$bn/dataset-1_bow_active_001.bvh" "$bn/dataset-1_run_happy_001.bvh")
cmu_files=("$data/cmu/131_01.bvh" "$data/cmu/131_03.bvh")
need_files "${bn_files[@]}" "${cmu_files[@]}"

status=0
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cm --random 8 \
  "${bn_files[@]}" || status=1
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cmu --random 8 \
  "${cmu_files[@]}" || status=1
exit $status
