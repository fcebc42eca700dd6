#!/usr/bin/env bash
# BVH from other exporters (DATA_DIR/bvh-wild, one file per exporter or tool;
# MANIFEST.tsv gives origin, licence, unit, frames to check and `expect`).
# Every file the manifest marks `ok` must
#   - index: `mocap-index build` of all of them skips none;
#   - get the manifest's `unit` by detection (`any`: not checked);
#   - agree with Blender's importer to 1e-4 m at frames 0, a third and the
#     last (compare.py with detected unit and up axis; a Z-up file is compared
#     with Blender's positions rotated the way ours are, docs/crosscheck.md).
# A file marked otherwise must be refused, its `expect` naming the real defect
# as LINE: WORDS (e.g. `20: too few values`): inspect must fail with an error
# containing FILE:LINE: WORDS, and build must skip it with the reason
# containing line LINE: WORDS.
#   bash tests/cli/crosscheck_wild.sh BUILD_DIR DATA_DIR
# Exit 77 (skipped) when Blender or the data is missing; under CI=true a
# missing Blender fails. See docs/crosscheck.md and docs/units.md.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/crosscheck.sh" "$@"
need_python
need_blender

wild="$data/bvh-wild"
need_files "$wild/MANIFEST.tsv"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

status=0
fail() {
  echo "FAIL: $*" >&2
  status=1
}
ok_files=()
bad_files=()
while IFS=$'\t' read -r file _repo _path _commit _sha _bytes _licence exporter unit frames expect \
  _notes; do
  [ "$file" = "file" ] && continue # header
  path="$wild/$file"
  need_files "$path"
  if [ "$expect" != "ok" ]; then
    bad_files+=("$path")
    printf '%s\t%s\n' "$path" "$expect" >>"$tmp/bad.tsv"
    if "$bin" inspect "$path" --frame 0 --json >/dev/null 2>"$tmp/err"; then
      fail "$file: read, but the manifest says it is malformed ($expect)"
    elif ! grep -qF -- "$file:$expect" "$tmp/err"; then
      fail "$file: refused with '$(cat "$tmp/err")', expected an error naming '$expect'"
    else
      echo "refused as expected: $(cat "$tmp/err")"
    fi
    continue
  fi
  ok_files+=("$path")
  "$bin" inspect "$path" --frame 0 --json >"$tmp/first.json"
  read -r got count up < <(python3 -c 'import json,sys; d=json.load(open(sys.argv[1]))
print(d["unit"], d["frames"], d["up"])' "$tmp/first.json")
  echo "$file ($exporter): unit $got (manifest $unit), up $up, $count frames"
  if [ "$unit" != "any" ] && [ "$got" != "$unit" ]; then
    fail "$file: detected unit $got, manifest says $unit"
  fi
  [ "$frames" = "0,third,last" ] || fail "$file: unknown frames column '$frames'"
  python3 "$root/tests/crosscheck/compare.py" --bin "$bin" --ref blender \
    "$path" --frames 0 $((count / 3)) $((count - 1)) || fail "$file: differs from Blender"
done <"$wild/MANIFEST.tsv"

"$bin" build --out "$tmp/wild.h5" --quiet --json "${ok_files[@]}" "${bad_files[@]}" \
  >"$tmp/build.json" || true
touch "$tmp/bad.tsv"
python3 - "$tmp/build.json" "${#ok_files[@]}" "$tmp/bad.tsv" <<'PY' || status=1
import json, sys
b = json.load(open(sys.argv[1]))
ok = int(sys.argv[2])
bad = dict(line.rstrip("\n").split("\t", 1) for line in open(sys.argv[3]) if line.strip())
skipped = {s["path"]: s["reason"] for s in b["skipped"]}
wrong = sorted(set(skipped) - set(bad))
if wrong:
    sys.exit("FAIL: build skipped files the manifest marks ok: %s" % {p: skipped[p] for p in wrong})
if b["clips"] != ok:
    sys.exit("FAIL: build indexed %d clips, expected %d" % (b["clips"], ok))
missing = [p for p in bad if p not in skipped]
if missing:
    sys.exit("FAIL: build indexed malformed files: %s" % missing)
unnamed = {p: skipped[p] for p, words in bad.items() if "line " + words not in skipped[p]}
if unnamed:
    sys.exit("FAIL: build skipped malformed files without naming their defect: %s" % unnamed)
print("build: %d clips indexed, %d malformed skipped" % (ok, len(bad)))
PY
exit $status
