#!/usr/bin/env bash
# Cross-check: our forward kinematics (mocap-index inspect --json) against
# Blender's BVH importer run headless (tests/crosscheck/blender_fk.py), on
# Bandai Namco set-1 and CMU files, and CMU ASF/AMC takes converted to BVH by
# `mocap-index convert` (whose positions tests/cli/asf_amc.sh checks against
# the AMC read directly); world joint positions must agree to 1e-4 m on
# sampled frames. See docs/crosscheck.md.
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

amc="$data/cmu-asf-amc"
need_files "$amc/charleston1.amc" "$amc/pirouette.amc"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$bin" convert "$amc/charleston1.amc" --asf "$amc/charleston.asf" --out "$tmp/charleston1.bvh"
"$bin" convert "$amc/pirouette.amc" --out "$tmp/pirouette.bvh"

status=0
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cmu --random 8 \
  "$tmp/charleston1.bvh" "$tmp/pirouette.bvh" || status=1
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cm --random 8 \
  "${bn_files[@]}" || status=1
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --unit cmu --random 8 \
  "${cmu_files[@]}" || status=1
exit $status
