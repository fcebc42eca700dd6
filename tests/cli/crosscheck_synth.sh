#!/usr/bin/env bash
# An output of mocap-synth loads identically in Blender and three.js: world
# joint positions of sampled frames agree with our forward kinematics
# (mocap-index inspect) to 1e-4 m (tests/crosscheck/compare.py). A Bandai
# Namco output (its pelvis carries the translation in position channels under
# a non-zero rest OFFSET, read as Blender reads them) is checked in Blender;
# three.js adds position channels to the OFFSET (docs/crosscheck.md), so it
# is checked on a CMU output, whose only joint with position channels is the
# root at OFFSET 0.
#   bash tests/cli/crosscheck_synth.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
[ -x "$build/synth/mocap-synth" ] || { echo "FAIL: mocap-synth not built" >&2; exit 1; }
[ -d "$data/bandai-namco-1/data" ] || { echo "SKIP: no data at $data"; exit 77; }
need_blender
need_three
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$bin" build --out "$tmp/index.h5" "$data/bandai-namco-1" "$data/cmu" >/dev/null 2>&1
python3 "$root/tests/synth/synth_fixture.py" --index-data "$data" --out "$tmp" >/dev/null
"$build/synth/mocap-synth" --index "$tmp/index.h5" --query "$tmp/query.json" --results "$tmp/results.jsonl" \
  --out "$tmp/synth-motion.bvh" >/dev/null
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender \
  --unit cm --random 6 "$tmp/synth-motion.bvh"
cmu="$(cd "$data/cmu" && pwd)"
cat > "$tmp/cmu-query.json" <<EOF
{"id": "cmu", "top": 3, "filter": {"clips": ["131_*"], "exclude": ["131_02.bvh"]},
 "frames": [{"bvh": "$cmu/131_02.bvh", "frame": 30}, {"bvh": "$cmu/131_02.bvh", "frame": 90}]}
EOF
"$build/synth/mocap-synth" --index "$tmp/index.h5" --query "$tmp/cmu-query.json" \
  --out "$tmp/synth-cmu.bvh" >/dev/null
python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender --ref three \
  --unit cmu --random 6 "$tmp/synth-cmu.bvh"
