#!/usr/bin/env bash
# mocap-index build / verify / info on real data: summary and info JSON,
# incremental rebuilds (touch, modify, remove, add), bad files and --strict,
# a build killed with SIGKILL midway, damaged copies (truncated, bit-flipped).
# Usage: index_build.sh BUILD_DIR DATA_DIR   (exit 77 = skipped: no data)
set -euo pipefail
bin="$1/indexer/mocap-index"
data="$2"
[ -d "$data/bandai-namco-1/data" ] || { echo "no data at $data"; exit 77; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
py=python3

# --- a build of set 1 + CMU, its summary, info and verify -------------------
"$bin" build --out "$tmp/all.h5" "$data/bandai-namco-1/data" "$data/cmu" --json -q > "$tmp/build.json"
"$bin" info "$tmp/all.h5" --json > "$tmp/info.json"
"$bin" verify "$tmp/all.h5" > "$tmp/verify.txt"
grep -q ": ok (" "$tmp/verify.txt"
$py - "$tmp" <<'PY'
import json, os, sys
tmp = sys.argv[1]
b = json.load(open(os.path.join(tmp, "build.json")))
assert b["clips"] == 177 and b["new"] == 177 and b["reused"] == 0 and b["skipped"] == [], b
assert b["frames"] > 30000 and b["index_bytes"] > 0 and b["frames_per_s"] > 0, b
i = json.load(open(os.path.join(tmp, "info.json")))
assert i["format"] == "mocap-index" and i["schema_version"] == 3, i
assert i["clips"] == 177 and i["frames"] == b["frames"], i
assert sum(s["clips"] for s in i["skeletons"]) == 177
assert sum(s["frames"] for s in i["skeletons"]) == i["frames"]
assert all(s["root_joint"] == "Hips" for s in i["skeletons"]), i["skeletons"]
# label histogram: 15 styles x content; the three CMU clips have none
assert i["labels"]["content"]["(none)"] == 3, i["labels"]["content"]
assert i["labels"]["content"]["walk"] >= 10 and i["labels"]["style"]["happy"] >= 10, i["labels"]
assert sum(i["labels"]["style"].values()) == 177
assert i["parameters"]["unit"] == "auto" and i["parameters"]["transition_time_s"] == 0.5
assert i["parameters"]["character"]["total_mass_kg"] == 70.0
print("build/info/verify ok")
PY
"$bin" info "$tmp/all.h5" | grep -q "177 clips"

# --- incremental: touch, modify, remove, add ---------------------------------
mkdir -p "$tmp/in"
ls "$data/bandai-namco-1/data"/*.bvh > "$tmp/all-list"
head -11 "$tmp/all-list" > "$tmp/list"
head -10 "$tmp/list" | xargs -I{} cp -p {} "$tmp/in/"
cp -p "$data"/cmu/*.bvh "$tmp/in/"
"$bin" build --out "$tmp/inc.h5" "$tmp/in" --json -q > "$tmp/b1.json"
f1=$(ls "$tmp/in"/dataset-1_*.bvh | sed -n 1p)
f2=$(ls "$tmp/in"/dataset-1_*.bvh | sed -n 2p)
f3=$(ls "$tmp/in"/dataset-1_*.bvh | sed -n 3p)
touch -d "+1 minute" "$f1"                 # same bytes, new mtime: parsed again
echo "" >> "$f2"                           # new size and hash
rm "$f3"                                   # removed
cp -p "$(sed -n 11p "$tmp/list")" "$tmp/in/"   # new
"$bin" build --out "$tmp/inc.h5" "$tmp/in" --json -q > "$tmp/b2.json"
"$bin" build --out "$tmp/inc.h5" "$tmp/in" --json -q > "$tmp/b3.json"
$py - "$tmp" <<'PY'
import json, os, sys
tmp = sys.argv[1]
b1, b2, b3 = (json.load(open(os.path.join(tmp, n))) for n in ("b1.json", "b2.json", "b3.json"))
assert (b1["new"], b1["clips"]) == (13, 13), b1
assert (b2["reused"], b2["changed"], b2["new"], b2["removed"]) == (10, 2, 1, 1), b2
assert b2["clips"] == 13 and not b2["up_to_date"], b2
assert b3["up_to_date"] and b3["reused"] == 13 and b3["changed"] + b3["new"] + b3["removed"] == 0, b3
print("incremental ok")
PY
"$bin" verify "$tmp/inc.h5" > /dev/null

# --- bad files are skipped; --strict fails and keeps the previous index -------
printf 'HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 2 Xposition Wrotation\n}\n' > "$tmp/in/zz-bad.bvh"
: > "$tmp/in/zz-empty.bvh"
set +e
"$bin" build --out "$tmp/inc.h5" "$tmp/in" -q > "$tmp/bad.txt"; rc=$?
set -e
[ $rc -eq 1 ] || { echo "expected exit 1 with skipped files, got $rc"; exit 1; }
grep -q "skipped .*zz-bad.bvh: line 5" "$tmp/bad.txt" || { cat "$tmp/bad.txt"; exit 1; }
grep -q "skipped .*zz-empty.bvh: empty file" "$tmp/bad.txt" || { cat "$tmp/bad.txt"; exit 1; }
before=$(md5sum < "$tmp/inc.h5")
touch "$tmp/in/zz-bad.bvh"
set +e
"$bin" build --strict --out "$tmp/inc.h5" "$tmp/in" -q > /dev/null 2> "$tmp/strict.err"; rc=$?
set -e
[ $rc -eq 2 ] || { echo "expected exit 2 under --strict, got $rc"; exit 1; }
grep -q "zz-bad.bvh" "$tmp/strict.err"
[ "$(md5sum < "$tmp/inc.h5")" = "$before" ] || { echo "--strict changed the previous index"; exit 1; }
rm "$tmp/in/zz-bad.bvh" "$tmp/in/zz-empty.bvh"
echo "bad files ok"

# --- SIGKILL midway leaves the previous index intact ------------------------
cp "$tmp/inc.h5" "$tmp/kill.h5"
before=$(md5sum < "$tmp/kill.h5")
"$bin" build --full --out "$tmp/kill.h5" -j 1 "$data/bandai-namco-1/data" "$data/cmu" -q > /dev/null 2>&1 &
pid=$!
for _ in $(seq 1 200); do   # wait until the temporary file is being written
  t=$(ls "$tmp"/.kill.h5.tmp-* 2>/dev/null || true)
  [ -n "$t" ] && [ "$(stat -c %s $t 2>/dev/null || echo 0)" -gt 1000000 ] && break
  sleep 0.02
done
kill -9 $pid
wait $pid 2>/dev/null || true
[ "$(md5sum < "$tmp/kill.h5")" = "$before" ] || { echo "killed build changed the index"; exit 1; }
"$bin" verify "$tmp/kill.h5" > /dev/null
ls "$tmp"/.kill.h5.tmp-* > /dev/null 2>&1 || { echo "the build was not killed midway (no temporary file)"; exit 1; }
"$bin" build --out "$tmp/kill.h5" "$tmp/in" -q > /dev/null          # next build cleans up
if ls "$tmp"/.kill.h5.tmp-* > /dev/null 2>&1; then echo "stale temporary file left"; exit 1; fi
echo "SIGKILL ok"

# --- damaged copies: a clear error, exit 1, never a crash --------------------
size=$(stat -c %s "$tmp/inc.h5")
check_damaged() {
  local f="$1" what="$2"
  set +e
  "$bin" verify "$f" > /dev/null 2> "$tmp/v.err"; local rc=$?
  set -e
  [ $rc -eq 1 ] || { echo "verify on $what: exit $rc (want 1)"; cat "$tmp/v.err"; exit 1; }
  grep -q "verification FAILED" "$tmp/v.err" || { echo "no clear message for $what"; cat "$tmp/v.err"; exit 1; }
  set +e
  "$bin" info "$f" > /dev/null 2> "$tmp/i.err"; rc=$?
  set -e
  [ $rc -lt 128 ] || { echo "info on $what crashed: exit $rc"; exit 1; }   # info does not hash: it may pass
}
for keep in $((size - 1)) $((size / 2)) 4096 600 10; do
  head -c $keep "$tmp/inc.h5" > "$tmp/trunc.h5"
  check_damaged "$tmp/trunc.h5" "truncated to $keep"
  [ $keep -lt 512 ] || grep -q "truncated" "$tmp/v.err" || { cat "$tmp/v.err"; exit 1; }
done
for off in 100 700 2048 $((size / 3)) $((size / 2)) $((size - 200)); do
  cp "$tmp/inc.h5" "$tmp/flip.h5"
  $py -c "
import sys
p, off = sys.argv[1], int(sys.argv[2])
with open(p, 'r+b') as f:
    f.seek(off); b = f.read(1); f.seek(off); f.write(bytes([b[0] ^ 0x40]))
" "$tmp/flip.h5" $off
  check_damaged "$tmp/flip.h5" "bit flip at $off"
done
echo "damaged copies ok"
