#!/usr/bin/env bash
# --out's extension picks the motion format (docs/cli.md "Motion formats"):
# mocap-search export and mocap-synth write .glb (glTF binary: "glTF", version
# 2, its length in its header) and .npz (a zip of NAME.npy: positions,
# rotations, translations, names, parents, fps), any other name BVH; an
# empty motion is refused before anything is written; the output-path policy
# for the two kinds (ours replaced; a file of another kind refused without
# --force, kept as it was). Their contents against our forward kinematics,
# three.js and Blender: tests/cli/crosscheck_gltf.sh.
#   bash tests/cli/motion_formats.sh BUILD_DIR DATA_DIR
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
cli_setup motion_formats "$@"
d="$data/bandai-namco-1/data"
mkdir "$tmp/data"
ln -s "$d/dataset-1_walk_normal_001.bvh" "$d/dataset-1_run_active_001.bvh" "$tmp/data/"
"$indexer" build -q --out "$tmp/index.h5" "$tmp/data" >/dev/null 2>&1 || fail "indexing failed"
export_to() {  # export_to OUT [more args]: frames 0-9 of the walk
  local out="$1"
  shift
  "$search" export --index "$tmp/index.h5" --clip dataset-1_walk_normal_001.bvh --frames 0-9 \
    --out "$out" "$@"
}

# The format by extension (any case).
for out in m.glb M.GLB m.npz m.bvh m.txt; do export_to "$tmp/$out" >/dev/null; done
[ "$(head -c 4 "$tmp/m.glb")" = glTF ] || fail "m.glb does not start with glTF"
cmp -s "$tmp/m.glb" "$tmp/M.GLB" || fail "M.GLB differs from m.glb"
[ "$(od -An -tu4 -j4 -N8 "$tmp/m.glb" | xargs)" = "2 $(stat -c %s "$tmp/m.glb")" ] ||
  fail "m.glb's header is not version 2 and its length"
[ "$(head -c 4 "$tmp/m.npz" | od -An -c | xargs)" = 'P K 003 004' ] || fail "m.npz is not a zip"
for name in positions rotations translations names parents fps; do
  grep -qa "$name.npy" "$tmp/m.npz" || fail "m.npz has no $name.npy"
done
head -1 "$tmp/m.bvh" | grep -q '^HIERARCHY' || fail "m.bvh is not BVH"
cmp -s "$tmp/m.bvh" "$tmp/m.txt" || fail "m.txt is not the BVH"

# The output-path policy: ours replaced, another kind refused and kept.
export_to "$tmp/m.glb" >/dev/null
export_to "$tmp/m.npz" >/dev/null
echo "notes" >"$tmp/notes.glb"
cp "$tmp/notes.glb" "$tmp/notes.npz"
cp "$tmp/m.npz" "$tmp/zip.glb"
for out in notes.glb notes.npz zip.glb; do
  cp "$tmp/$out" "$tmp/before"
  rc=0
  export_to "$tmp/$out" >/dev/null 2>"$tmp/err" || rc=$?
  [ "$rc" = 2 ] || fail "exit $rc (expected 2) writing over $out"
  grep -q -- "--force" "$tmp/err" || { cat "$tmp/err" >&2; fail "no --force hint for $out"; }
  cmp -s "$tmp/$out" "$tmp/before" || fail "$out changed"
done
export_to "$tmp/notes.glb" --force >/dev/null
[ "$(head -c 4 "$tmp/notes.glb")" = glTF ] || fail "--force did not replace notes.glb"

# mocap-synth: the same formats; a text file is not replaced (its exit status is 1).
cat >"$tmp/query.json" <<Q
{"id": "walk-run", "top": 2, "frames": [{"bvh": "$d/dataset-1_walk_normal_001.bvh", "frame": 10},
  {"bvh": "$d/dataset-1_run_active_001.bvh", "frame": 40}]}
Q
"$synth" --index "$tmp/index.h5" --query "$tmp/query.json" --out "$tmp/s.glb" >/dev/null ||
  fail "mocap-synth --out s.glb failed"
[ "$(head -c 4 "$tmp/s.glb")" = glTF ] || fail "s.glb does not start with glTF"
"$synth" --index "$tmp/index.h5" --query "$tmp/query.json" --out "$tmp/s.npz" >/dev/null ||
  fail "mocap-synth --out s.npz failed"
[ "$(head -c 2 "$tmp/s.npz")" = PK ] || fail "s.npz is not a zip"
rc=0
"$synth" --index "$tmp/index.h5" --query "$tmp/query.json" --out "$tmp/notes.npz" \
  >/dev/null 2>&1 || rc=$?
[ "$rc" = 1 ] || fail "mocap-synth wrote over a text file as .npz (exit $rc)"

# The help names the formats.
"$search" export --help >"$tmp/help-export.txt"
grep -q 'M\.glb glTF 2\.0 binary' "$tmp/help-export.txt" || fail "mocap-search export --help: no .glb"
"$synth" --help >"$tmp/help-synth.txt"
grep -q 'M\.npz' "$tmp/help-synth.txt" || fail "mocap-synth --help does not name .npz"
echo "ok: .glb and .npz by extension, output paths"
