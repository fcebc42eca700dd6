#!/usr/bin/env bash
# The house limits on function length (docs/architecture.md "Functions"): no
# library function over 120 lines, no main() over 80, counted by
# scripts/function-lengths on the source tree; and the counter itself finds
# a long function in a small hand-written file.
#   bash tests/cli/function_lengths.sh BUILD_DIR DATA_DIR   (neither is read)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
fail() { echo "FAIL: $*" >&2; exit 1; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/common/src"
{
  echo "namespace x {"
  echo "int long_one(int a) {"
  for i in $(seq 1 130); do echo "  a += $i;"; done
  echo "  return a;"
  echo "}"
  echo "int main() {"
  for i in $(seq 1 85); do echo "  long_one($i);"; done
  echo "}"
  echo "}  // namespace x"
} >"$tmp/common/src/long.cpp"
out="$("$root/scripts/function-lengths" --check "$tmp" || true)"
grep -q "long_one" <<<"$out" || { echo "$out" >&2; fail "the counter misses a 134-line function"; }
grep -q " main " <<<"$out" || { echo "$out" >&2; fail "the counter misses an 87-line main"; }
"$root/scripts/function-lengths" --check "$root" || fail "functions over the house limits (above)"
