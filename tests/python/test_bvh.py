"""BVH from Python: reading files to numpy arrays and writing arrays to BVH,
with the libraries' reader, writer and forward kinematics; checked against
the index's own poses of the same files and by round trips."""
import os

import numpy as np
import pytest

import mocap
from conftest import SOURCE_DIR, set1

GOLDEN = os.path.join(SOURCE_DIR, "tests", "data", "index", "golden_walk_normal_001.bvh")


def tiny_arrays():
    """A 3-joint chain, 2 frames: names, parents, offsets, rotations, root positions."""
    names = ["Hips", "Spine", "Head"]
    parents = [-1, 0, 1]
    offsets = np.array([[0, 0, 0], [0, 10, 0], [0, 20, 0]], dtype=float)
    quarter = [np.cos(np.pi / 8), 0, 0, np.sin(np.pi / 8)]  # 45 degrees about Z
    rotations = np.array([[[1, 0, 0, 0]] * 3, [quarter, [1, 0, 0, 0], quarter]], dtype=float)
    root = np.array([[0, 90, 0], [5, 90, 0]], dtype=float)
    return names, parents, offsets, rotations, root


# Invalid inputs first.

def test_malformed_text_names_the_line():
    with pytest.raises(mocap.InputError) as e:
        mocap.parse_bvh("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 zero 0\n", source="bad.bvh")
    assert e.value.source == "bad.bvh" and e.value.line == 4


def test_missing_file(scratch):
    path = os.path.join(scratch, "none.bvh")
    with pytest.raises(mocap.InputError, match="none.bvh"):
        mocap.read_bvh(path)


def test_arrays_of_the_wrong_shape():
    names, parents, offsets, rotations, root = tiny_arrays()
    with pytest.raises(ValueError, match=r"rotations: expected shape \(2, 3, 4\)"):
        mocap.Bvh.from_rotations(names, parents, offsets, rotations[:, :2], root, 1 / 30)
    with pytest.raises(ValueError, match="offsets"):
        mocap.Bvh.from_rotations(names, parents, offsets[:2], rotations, root, 1 / 30)
    with pytest.raises(ValueError, match="root_positions"):
        mocap.Bvh.from_rotations(names, parents, offsets, rotations, root[:1], 1 / 30)
    with pytest.raises(ValueError, match=r"parents\[1\]"):
        mocap.Bvh.from_rotations(names, [-1, 2, 1], offsets, rotations, root, 1 / 30)
    with pytest.raises(ValueError, match="order"):
        mocap.Bvh.from_rotations(names, parents, offsets, rotations, root, 1 / 30, order="XXY")
    with pytest.raises(ValueError, match="frame_time_s"):
        mocap.Bvh.from_rotations(names, parents, offsets, rotations, root, 0.0)
    zero = rotations.copy()
    zero[1, 2] = 0
    with pytest.raises(ValueError, match=r"rotations\[1, 2\]"):
        mocap.Bvh.from_rotations(names, parents, offsets, zero, root, 1 / 30)
    with pytest.raises(ValueError, match="not a BVH channel"):
        mocap.Bvh.from_channels(names, parents, offsets, [["Xpos"], [], []], np.zeros((1, 1)),
                                1 / 30)
    with pytest.raises(ValueError, match=r"values: expected shape \(frames, 4\)"):
        mocap.Bvh.from_channels(names, parents, offsets, [["Xposition", "Zrotation"], [],
                                                          ["Xrotation", "Yrotation"]],
                                np.zeros((2, 3)), 1 / 30)
    with pytest.raises(mocap.InputError, match="joint name"):
        mocap.Bvh.from_rotations(["Hips", "Spine {", "Head"], parents, offsets, rotations, root,
                                 1 / 30).text()


# Reading.

def test_read_file_as_arrays():
    bvh = mocap.read_bvh(GOLDEN)
    assert bvh.joint_names[:3] == ["Hips", "Spine", "Neck"]
    assert bvh.parents[:4].tolist() == [-1, 0, 1, 2]
    assert bvh.offsets[1].tolist() == [0, 20, 0]
    assert bvh.end_sites[3].tolist() == [0, 18, 0] and np.isnan(bvh.end_sites[0]).all()
    assert bvh.channels[0] == ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation",
                               "Yrotation"]
    assert bvh.values.shape == (bvh.frame_count, bvh.channel_count)
    assert bvh.channel_count == sum(len(c) for c in bvh.channels)
    assert not bvh.values.flags.writeable
    # The first frame line, as written.
    with open(GOLDEN) as f:
        lines = f.read().splitlines()
    first = lines[lines.index("MOTION") + 3]
    assert bvh.values[0].tolist() == [float(v) for v in first.split()]


def test_poses_match_the_index(index, data_dir):
    """Forward kinematics of the file equals the index's stored poses (float32)."""
    for clip in (index.clip("dataset-1_walk_normal_001"), index.clip("131_01")):
        bvh = mocap.read_bvh(clip.path)
        assert bvh.detect_unit() == clip.unit
        assert bvh.joint_names == clip.skeleton.joint_names
        motion = bvh.motion(clip.unit)
        assert motion["unit_scale_m"] == clip.unit_scale_m
        assert motion["joint_positions_m"].shape == clip.joint_positions.shape
        assert np.abs(motion["joint_positions_m"] - clip.joint_positions).max() < 1e-5
        q, r = motion["local_rotations"], clip.local_rotations
        same = np.minimum(np.abs(q - r).max(axis=2), np.abs(q + r).max(axis=2))  # q ~ -q
        assert same.max() < 1e-6
        assert bvh.frame_time_s == clip.frame_time_s


# Writing.

def test_arrays_to_bvh_and_back(scratch):
    names, parents, offsets, rotations, root = tiny_arrays()
    path = os.path.join(scratch, "tiny.bvh")
    written = mocap.write_bvh(path, names, parents, offsets, rotations, root, 1 / 30,
                              end_sites=np.array([[np.nan] * 3, [np.nan] * 3, [0, 5, 0]]))
    back = mocap.read_bvh(path)
    assert back.joint_names == names and back.parents.tolist() == parents
    assert back.channels == [["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation",
                              "Yrotation"], ["Zrotation", "Xrotation", "Yrotation"],
                             ["Zrotation", "Xrotation", "Yrotation"]]
    assert np.allclose(back.values, written.values, rtol=1e-9, atol=1e-12)
    assert back.end_sites[2].tolist() == [0, 5, 0]
    m = back.motion("cm")
    assert np.allclose(np.abs(np.sum(m["local_rotations"] * rotations, axis=2)), 1.0)
    # Frame 1: the hips at (5, 90, 0) cm turned 45 degrees about Z; the spine
    # 10 cm up the turned hips; the head 20 cm further, turned 90 degrees.
    s = np.sqrt(0.5)
    hips, spine, head = m["joint_positions_m"][1] * 100
    assert np.allclose(hips, [5, 90, 0])
    assert np.allclose(spine, [5 - 10 * s, 90 + 10 * s, 0])
    assert np.allclose(head, spine + [-20 * s, 20 * s, 0])
    assert np.allclose(back.values[1, :6], [5, 90, 0, 45, 0, 0])


@pytest.mark.parametrize("name", ["dataset-1_walk_normal_001", "131_02"])
def test_real_clip_round_trips(data_dir, name, scratch):
    path = set1(name) if name.startswith("dataset") else os.path.join(data_dir, "cmu",
                                                                      name + ".bvh")
    original = mocap.read_bvh(path)
    unit = original.detect_unit()
    # Channels as read -> the same text.
    copy = mocap.Bvh.from_channels(original.joint_names, original.parents, original.offsets,
                                   original.channels, original.values, original.frame_time_s,
                                   end_sites=original.end_sites)
    assert copy.text() == original.text()
    # Rotations and root positions (the export layout: positions on the root
    # only) -> the same joint positions.
    layout = original.export_layout()
    m = layout.motion(unit)
    root_positions = m["local_translations_m"][:, 0] / m["unit_scale_m"]
    rebuilt = mocap.Bvh.from_rotations(layout.joint_names, layout.parents, layout.offsets,
                                       m["local_rotations"], root_positions,
                                       layout.frame_time_s, order="ZYX",
                                       end_sites=layout.end_sites)
    out = os.path.join(scratch, "rebuilt.bvh")
    rebuilt.write(out)
    again = mocap.read_bvh(out)
    assert again.frame_count == original.frame_count
    assert np.abs(again.joint_positions(unit) - layout.joint_positions(unit)).max() < 1e-6
    # The export layout keeps every joint where it was but a static root
    # above a moving pelvis (Bandai Namco's joint_Root), which moves with it.
    kept = original.joint_positions(unit)[:, 1:]
    assert np.abs(again.joint_positions(unit)[:, 1:] - kept).max() < 1e-6
