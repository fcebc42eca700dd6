#!/usr/bin/env bash
# Index build benchmark on Bandai Namco set 2 (2,902 clips, 384,931 frames,
# ~509 MB of text): wall time, CPU time and peak RSS (/usr/bin/time -v) for
# --jobs 1 and 2, index size, an incremental rebuild with nothing changed,
# one with one file changed, and peak RSS for a collection 4x larger (set 2
# listed four times under different names through symlinked folders).
#
# Usage: bench/index_build.sh [BUILD_DIR] [DATA_DIR]
#   BUILD_DIR  default build-index (needs indexer/mocap-index)
#   DATA_DIR   default ../shared/data (holds bandai-namco-2.tar.zst)
#   BENCH_4X=0 skips the 4x collection (it writes a ~4.5 GB index).
#   Set 2 is unpacked once to /tmp/mocap-bandai-namco-2 (or $MOCAP_BN2_DIR).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$here/build-index}"
data="${2:-$here/../shared/data}"
bin="$build/indexer/mocap-index"
[ -x "$bin" ] || { echo "no $bin: build the indexer first"; exit 1; }
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (GNU time)"; exit 1; }

set2="${MOCAP_BN2_DIR:-/tmp/mocap-bandai-namco-2/bandai-namco-2/data}"
cache=/tmp/mocap-bandai-namco-2
if [ -z "${MOCAP_BN2_DIR:-}" ] && [ ! -f "$cache/.unpacked" ]; then
  # Into a folder of this process's own, then renamed into place (no reader
  # ever sees a half-written cache; tests/test_support.cpp does the same).
  mine="$cache.tmp-$$"
  rm -rf "$mine" && mkdir -p "$mine"
  tar --zstd -xf "$data/bandai-namco-2.tar.zst" -C "$mine" && : >"$mine/.unpacked"
  if ! mv -T "$mine" "$cache" 2>/dev/null && [ ! -f "$cache/.unpacked" ]; then
    rm -rf "$cache" && mv -T "$mine" "$cache"
  fi
  rm -rf "$mine"
fi
work=$(mktemp -d /tmp/mocap-index-bench.XXXXXX)
trap 'rm -rf "$work"' EXIT
out="$work/set2.h5"

# Runs the command under /usr/bin/time -v; prints "label: wall s, user s, sys s, peak RSS".
measure() {
  local label="$1"; shift
  /usr/bin/time -v "$@" > "$work/stdout" 2> "$work/time"
  local wall user sys rss
  wall=$(grep "Elapsed (wall clock)" "$work/time" | awk '{print $NF}')
  user=$(grep "User time" "$work/time" | awk '{print $NF}')
  sys=$(grep "System time" "$work/time" | awk '{print $NF}')
  rss=$(grep "Maximum resident set size" "$work/time" | awk '{print $NF}')
  printf '%-38s wall %8s   user %7s s   sys %6s s   peak RSS %6.0f MB\n' "$label" "$wall" "$user" "$sys" "$(echo "$rss / 1024" | bc -l)"
  grep -E "clips|new|s, " "$work/stdout" | sed 's/^/    /'
}

echo "machine: $(nproc) cores, $(uptime | sed 's/.*load average/load average/')"
echo "set 2: $(ls "$set2"/*.bvh | wc -l) files, $(du -sh "$set2" | cut -f1) in $set2"
cat "$set2"/*.bvh > /dev/null   # warm the page cache: measure the indexer, not the disk

measure "full build, --jobs 1" "$bin" build --full --jobs 1 -q --out "$out" "$set2"
measure "full build, --jobs 2" "$bin" build --full --jobs 2 -q --out "$out" "$set2"
echo "index size: $(stat -c %s "$out") bytes ($(du -h "$out" | cut -f1))"
measure "incremental, nothing changed" "$bin" build --jobs 2 -q --out "$out" "$set2"

# One file changed: every other clip is copied from the previous index.
mkdir -p "$work/set2-copy"
cp -p "$set2"/*.bvh "$set2"/*.json "$work/set2-copy/" 2>/dev/null || cp -p "$set2"/*.bvh "$work/set2-copy/"
measure "full build of the copy, --jobs 2" "$bin" build --full --jobs 2 -q --out "$work/copy.h5" "$work/set2-copy"
first=$(ls "$work/set2-copy"/*.bvh | sed -n 1p)
echo "" >> "$first"
measure "incremental, one file changed" "$bin" build --jobs 2 -q --out "$work/copy.h5" "$work/set2-copy"
rm -rf "$work/set2-copy" "$work/copy.h5"

measure "verify" "$bin" verify "$out"

if [ "${BENCH_4X:-1}" != "0" ]; then
  mkdir -p "$work/x4"
  for i in 1 2 3 4; do ln -s "$set2" "$work/x4/copy$i"; done
  measure "4x collection, --jobs 2" "$bin" build --full --jobs 2 -q --out "$work/x4.h5" "$work/x4"
  echo "4x index size: $(stat -c %s "$work/x4.h5") bytes"
fi
