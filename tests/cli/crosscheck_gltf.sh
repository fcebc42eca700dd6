#!/usr/bin/env bash
# A motion written as glTF binary (.glb) and as NumPy arrays (.npz) is the
# motion of its BVH: three.js's GLTFLoader and Blender's glTF importer load
# the .glb with world joint positions equal to our forward kinematics of the
# BVH (mocap-index inspect) to 1e-4 m on sampled frames, and the .npz's
# positions (numpy's np.load) equal them too (tests/crosscheck/
# compare_motion.py). Checked on a partial motion (`mocap-search export`) and
# a synthesised one (`mocap-synth`), both of Bandai Namco set 1 (a static
# joint_Root above a Hips with position channels under a non-zero OFFSET).
# scripts/blender-import saves a .blend of each. The formats by extension and
# the output-path policy: tests/cli/motion_formats.sh.
#   bash tests/cli/crosscheck_gltf.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
search="$build/search/mocap-search"
synth="$build/synth/mocap-synth"
[ -x "$search" ] && [ -x "$synth" ] || { echo "FAIL: mocap-search or mocap-synth not built" >&2; exit 1; }
bn="$data/bandai-namco-1/data"
need_files "$bn/dataset-1_walk_normal_001.bvh" "$bn/dataset-1_run_active_001.bvh"
need_python
need_three
need_blender
# numpy for the .npz check: python3, or Debian's own when a pyenv one lacks it.
py=""
for p in python3 /usr/bin/python3; do
  if "$p" -c 'import numpy' >/dev/null 2>&1; then py="$p"; break; fi
done
[ -n "$py" ] || skip "numpy not found (apt-get install python3-numpy)"

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir "$tmp/data"
for f in "$bn"/dataset-1_walk_normal_00[1-3].bvh "$bn"/dataset-1_run_active_00[1-3].bvh; do
  ln -s "$f" "$tmp/data/"
done
"$bin" build --out "$tmp/index.h5" "$tmp/data" >/dev/null 2>&1

compare() {  # compare STEM: STEM.bvh against STEM.glb (three.js, Blender) and STEM.npz
  "$py" "$root/tests/crosscheck/compare_motion.py" --bin "$bin" --unit cm --random 6 \
    --bvh "$1.bvh" --glb "$1.glb" --npz "$1.npz" --ref three --ref blender
}

# A partial motion, in the three formats.
for ext in bvh glb npz; do
  "$search" export --index "$tmp/index.h5" --clip dataset-1_walk_normal_001.bvh --frames 5-64 \
    --out "$tmp/piece.$ext" >/dev/null
done
compare "$tmp/piece"

# A synthesised motion (the search runs in mocap-synth).
cat >"$tmp/query.json" <<EOF
{"id": "walk-run", "top": 3, "frames": [{"bvh": "$bn/dataset-1_walk_normal_001.bvh", "frame": 10},
  {"bvh": "$bn/dataset-1_run_active_001.bvh", "frame": 40}]}
EOF
for ext in bvh glb npz; do
  "$synth" --index "$tmp/index.h5" --query "$tmp/query.json" --out "$tmp/synth.$ext" >/dev/null
done
compare "$tmp/synth"

# scripts/blender-import: a .blend of the .glb and of the .bvh (Debian 12's
# Blender 3.4 cannot import any BVH without its workaround).
"$py" "$root/scripts/blender-import" "$tmp/piece.glb" >"$tmp/import.log" 2>&1 &&
  "$py" "$root/scripts/blender-import" "$tmp/piece.bvh" --scale 0.01 --out "$tmp/bvh.blend" \
    >>"$tmp/import.log" 2>&1 || { cat "$tmp/import.log" >&2; echo "FAIL: blender-import" >&2; exit 1; }
for f in "$tmp/piece.blend" "$tmp/bvh.blend"; do
  [ "$(head -c 7 "$f")" = BLENDER ] || { echo "FAIL: $f is not a .blend" >&2; exit 1; }
done
echo "ok: .glb and .npz outputs match our forward kinematics (three.js, Blender, numpy); blender-import"
