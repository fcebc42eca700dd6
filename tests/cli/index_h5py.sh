#!/usr/bin/env bash
# The index is self-describing: h5py (Debian python3-h5py, for /usr/bin/python3)
# reads every dataset; every dataset carries unit, description and checksum
# attributes; frame arrays say their axes; h5dump -H shows the schema.
# Usage: index_h5py.sh BUILD_DIR DATA_DIR   (exit 77 = skipped: no h5py)
set -euo pipefail
bin="$1/indexer/mocap-index"
data="$2"
src="$(cd "$(dirname "$0")/../.." && pwd)"
/usr/bin/python3 -c "import h5py" 2> /dev/null || { echo "no h5py for /usr/bin/python3"; exit 77; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

inputs=("$src/tests/data/index/golden_walk_normal_001.bvh" "$src/tests/data/index/golden_jump_happy_002.bvh")
[ -d "$data/cmu" ] && inputs+=("$data/cmu")
"$bin" build --out "$tmp/i.h5" "${inputs[@]}" -q > /dev/null

if command -v h5dump > /dev/null; then
  h5dump -H "$tmp/i.h5" > "$tmp/dump.txt"
  grep -q 'GROUP "frames"' "$tmp/dump.txt"
  grep -q 'ATTRIBUTE "unit"' "$tmp/dump.txt"
  grep -q 'DATASET "local_rotations"' "$tmp/dump.txt"
fi

/usr/bin/python3 - "$tmp/i.h5" <<'PY'
import sys
import h5py
import numpy as np

f = h5py.File(sys.argv[1], "r")
a = f.attrs
assert a["format"] == "mocap-index", a["format"]
assert int(a["schema_version"]) == 3
for k, v in (("length_unit", "m"), ("time_unit", "s"), ("mass_unit", "kg"), ("energy_unit", "J"), ("up_axis", "Y")):
    assert a[k] == v, (k, a[k])
for k in ("build_tool", "build_time_utc", "character", "transition_time_s", "clip_count", "frame_count"):
    assert k in a, k

expected_units = {
    "root_position_m": "m", "local_rotations": "1", "world_rotations": "1", "joint_positions_m": "m",
    "segment_com_m": "m", "segment_com_velocity_mps": "m/s", "segment_angular_velocity_radps": "rad/s",
    "kd_features": "sqrt(J)", "energy_prefix_J": "J", "root_min_m": "m", "root_max_m": "m",
    "rotation_channel_min_deg": "deg", "mass_kg": "kg", "offsets_m": "m", "inertia_local_kgm2": "kg m^2",
    "frame_time_s": "s", "size_bytes": "B", "mtime_ns": "ns",
}
seen = []
def visit(name, obj):
    if not isinstance(obj, h5py.Dataset):
        return
    seen.append(name)
    for k in ("unit", "description", "checksum_xxh64"):
        assert k in obj.attrs, (name, k)
    assert len(obj.attrs["description"]) > 5, name
    leaf = name.split("/")[-1]
    if leaf in expected_units:
        assert obj.attrs["unit"] == expected_units[leaf], (name, obj.attrs["unit"])
    if "/frames/" in name or "/blocks" in name or "/clip_bounds/" in name:
        assert "axes" in obj.attrs, name
        assert obj.dtype in (np.float32, np.float64), (name, obj.dtype)
    value = obj[()]                      # every dataset reads
    if obj.dtype.kind == "f":
        assert np.all(np.isfinite(value)), name
f.visititems(visit)
assert len(seen) > 60, len(seen)

clips = f["clips"]
C = int(a["clip_count"])
assert clips["path"].shape == (C,)
paths = [p.decode() if isinstance(p, bytes) else p for p in clips["path"][()]]
assert paths == sorted(paths)
status = h5py.check_enum_dtype(clips["status"].dtype)
assert status == {"new": 0, "changed": 1, "reused": 2}, status
keys = [k.decode() if isinstance(k, bytes) else k for k in clips["label_keys"][()]]
assert keys == ["content", "style"], keys
assert clips["labels"].shape == (C, 2)
total = 0
for k in f["skeletons"]:
    g = f["skeletons"][k]
    J = int(g.attrs["joint_count"]); S = int(g.attrs["segment_count"]); N = int(g.attrs["frame_count"])
    fr = g["frames"]
    assert fr["local_rotations"].shape == (N, J, 4)
    # derived on load by the reader (docs/index-format.md "Versions"), not stored
    for name in ("world_rotations", "segment_com_m", "segment_com_velocity_mps",
                 "segment_angular_velocity_radps", "h_scan", "kd_features"):
        assert name not in fr, name
    assert fr["joint_positions_m"].shape == (N, J, 3)
    assert g["blocks16"]["kd_min"].shape[1:] == (S, 3)
    assert fr["energy_prefix_J"].shape == (N,)
    q = fr["local_rotations"][()]
    assert np.allclose(np.linalg.norm(q, axis=2), 1.0, atol=1e-5)
    assert g["names"].shape == (J,) and g["inertia_local_kgm2"].shape == (J, 3, 3)
    total += N
    # a clip's rows: frame_start .. + frame_count; its bounds contain them
    mine = np.nonzero(clips["skeleton"][()] == int(k))[0]
    for c in mine:
        s0, n, row = int(clips["frame_start"][c]), int(clips["frame_count"][c]), int(clips["row"][c])
        root = fr["root_position_m"][s0:s0 + n]
        assert np.all(root >= g["clip_bounds"]["root_min_m"][row] - 1e-7)
        assert np.all(root <= g["clip_bounds"]["root_max_m"][row] + 1e-7)
        assert fr["energy_prefix_J"][s0] == 0.0
assert total == int(a["frame_count"]) == int(clips["frame_count"][()].sum())
print("h5py: %d datasets read, %d clips, %d frames" % (len(seen), C, total))
PY
