#!/usr/bin/env bash
# Cross-check: the ASF/AMC reader and our forward kinematics (the gtest
# AsfAmcCrosscheck.MatchesIndependentReference in common_asf_amc_test) against
# tests/crosscheck/asf_amc_fk.py, a plain-Python implementation of the Acclaim
# definition (row vectors, L = C^-1 M C B); world positions of every joint and
# leaf bone end must agree to 1e-4 m on the first, a middle and the last frame
# of each real CMU take (docs/asf-amc.md).
#   bash tests/cli/crosscheck_asf_amc.sh BUILD_DIR DATA_DIR
# Exit 77 (skipped) when the data or python3 is missing (python3: fails under CI=true).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"
build="${1:?usage: crosscheck_asf_amc.sh BUILD_DIR DATA_DIR}"
data="${2:?usage: crosscheck_asf_amc.sh BUILD_DIR DATA_DIR}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
dir="$data/cmu-asf-amc"
[ -d "$dir" ] || { echo "SKIP: no data at $dir"; exit 77; }
command -v python3 >/dev/null 2>&1 || missing_tool scripts/crosscheck-setup "python3 not found"
test_bin="$build/tests/common_asf_amc_test"
[ -x "$test_bin" ] || fail "$test_bin not built"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# ASF of each take: charleston1/2 share charleston.asf, the others X.asf.
takes=(backflip:backflip charleston:charleston1 charleston:charleston2 lambada:lambada
  pirouette:pirouette zombie:zombie)
parts=()
for t in "${takes[@]}"; do
  asf="$dir/${t%%:*}.asf"
  amc="$dir/${t#*:}.amc"
  last="$(grep -E '^[0-9]+[[:space:]]*$' "$amc" | tail -1 | tr -d '[:space:]')"
  [ -n "$last" ] || fail "$amc has no frame numbers"
  out="$tmp/${t#*:}.json"
  python3 "$root/tests/crosscheck/asf_amc_fk.py" "$asf" "$amc" 1 $(((last + 1) / 2)) "$last" \
    >"$out" || fail "asf_amc_fk.py failed on $amc"
  parts+=("$out")
done
# A synthetic take with what the CMU files lack: other rotation orders, a root
# orientation and position, radians, a partial root order and absent bones.
cat >"$tmp/synthetic.asf" <<'ASF'
:units
  length 1
  angle rad
:root
  order RZ TX RX TY TZ
  axis ZXY
  position 1 2 3
  orientation 0.3 -0.2 0.5
:bonedata
  begin
    name a
    direction 0.2 0.9 0.1
    length 2
    axis 0.4 0.1 -0.7 YZX
    dof rz rx ry
  end
  begin
    name b
    direction 1 0.1 0
    length 1.5
    axis -0.3 0.6 0.2 ZYX
    dof ry rx
  end
  begin
    name c
    direction 0 0 1
    length 1
    axis 0.1 0.2 0.3 XZY
    dof rx
  end
:hierarchy
  begin
    root a c
    a b
  end
ASF
cat >"$tmp/synthetic.amc" <<'AMC'
:FULLY-SPECIFIED
:RADIANS
1
root 0.5 1 0.2 -1 2
a 0.3 -1.2 0.7
b 0.9 1.4
c -0.4
2
root -2.5 0 1.4 0 0
b -0.3 0.2
AMC
python3 "$root/tests/crosscheck/asf_amc_fk.py" "$tmp/synthetic.asf" "$tmp/synthetic.amc" 1 2 \
  >"$tmp/synthetic.json" || fail "asf_amc_fk.py failed on the synthetic take"
parts+=("$tmp/synthetic.json")

python3 -c 'import json, sys; print(json.dumps(sum((json.load(open(p)) for p in sys.argv[1:]), [])))' \
  "${parts[@]}" >"$tmp/reference.json"
MOCAP_ASF_AMC_REFERENCE="$tmp/reference.json" "$test_bin" \
  --gtest_filter=AsfAmcCrosscheck.MatchesIndependentReference || fail "positions differ"
echo "OK: ASF/AMC world positions match the independent Acclaim implementation"
