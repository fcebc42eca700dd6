"""mocap.Index: opening, metadata and frame arrays, checked against what h5py
reads from the same file (the index layout: tests/cli/index_h5py.sh,
docs/index-format.md)."""
import gc
import os

import numpy as np
import pytest

import mocap
from conftest import SOURCE_DIR

h5py = pytest.importorskip("h5py")


def text(values):
    return [v.decode() if isinstance(v, bytes) else v for v in values]


# Invalid inputs first.

def test_missing_file_names_the_path(scratch):
    path = os.path.join(scratch, "missing.h5")
    with pytest.raises(mocap.InputError) as e:
        mocap.Index(path)
    assert e.value.source == path and e.value.line == 0
    assert "no such index file" in e.value.detail
    assert isinstance(e.value, ValueError)


def test_not_an_index_is_refused():
    path = os.path.join(SOURCE_DIR, "tests", "data", "index", "golden_walk_normal_001.bvh")
    with pytest.raises(mocap.InputError) as e:
        mocap.Index(path)
    assert path in str(e.value)


def test_truncated_index_is_refused(index_path, scratch):
    cut = os.path.join(scratch, "cut.h5")
    with open(index_path, "rb") as f, open(cut, "wb") as g:
        g.write(f.read(os.path.getsize(index_path) // 2))
    with pytest.raises(mocap.InputError) as e:
        mocap.Index(cut)
    assert cut in str(e.value)


def test_unknown_names_and_numbers(index):
    with pytest.raises(mocap.InputError, match="no field 'nope'.*joint_positions_m"):
        index.clips[0].frames("nope")
    with pytest.raises(mocap.InputError, match="expected frames, blocks16"):
        index.skeletons[0].array("frame", "root_position_m")
    with pytest.raises(IndexError):
        index._raw.clip_frames(len(index.clips), "root_position_m")
    with pytest.raises(IndexError):
        index._raw.array(len(index.skeletons), "frames", "root_position_m")
    with pytest.raises(KeyError, match="no clip"):
        index.clip("no_such_clip.bvh")
    with pytest.raises(KeyError, match="Hips"):
        index.skeletons[0].joint("NoSuchJoint")


# Metadata.

def test_clips_match_h5py(index, index_path):
    with h5py.File(index_path, "r") as f:
        clips = f["clips"]
        assert f.attrs["clip_count"] == len(index.clips)
        assert text(clips["label_keys"][()]) == index.label_keys == ["content", "style"]
        paths = text(clips["path"][()])
        labels = [text(row) for row in clips["labels"][()]]
        for c in index.clips:
            assert c.path == paths[c.number]
            assert c.name == os.path.basename(paths[c.number])
            assert c.frame_count == clips["frame_count"][c.number]
            assert c.frame_start == clips["frame_start"][c.number]
            assert c.frame_time_s == clips["frame_time_s"][c.number]
            assert c.skeleton_number == clips["skeleton"][c.number]
            assert c.unit_scale_m == clips["unit_scale_m"][c.number]
            want = {k: v for k, v in zip(index.label_keys, labels[c.number]) if v}
            assert c.labels == want
            assert np.array_equal(c.times, np.arange(c.frame_count) * c.frame_time_s)
        assert index.frame_count == f.attrs["frame_count"]
        assert index.info["clip_count"] == f.attrs["clip_count"]
        assert index.info["transition_time_s"] == f.attrs["transition_time_s"]
    cmu = [c for c in index.clips if c.name.startswith("131_")]
    assert len(cmu) == 3 and all(c.labels == {} and abs(c.fps - 120) < 0.01 for c in cmu)


def test_labels_and_find_clips(index):
    assert index.labels["content"] == ["bow", "bye", "run", "walk"]
    walks = index.find_clips(content="walk")
    assert walks and all(c.content == "walk" for c in walks)
    assert {c.name for c in walks} == {c.name for c in index.clips
                                       if c.name.startswith("dataset-1_walk_")}
    both = index.find_clips(content=["walk", "run"], style="normal")
    assert both and all(c.content in ("walk", "run") and c.style == "normal" for c in both)
    assert [c.name for c in index.find_clips(name="131_0[12].bvh")] == ["131_01.bvh", "131_02.bvh"]
    clip = walks[0]
    assert index.clip(clip.number) is clip
    assert index.clip(clip.path) is clip and index.clip(clip.name) is clip
    assert index.clip(clip.stem) is clip


def test_skeletons_match_h5py(index, index_path):
    with h5py.File(index_path, "r") as f:
        assert len(index.skeletons) == f.attrs["skeleton_count"] >= 2
        for s in index.skeletons:
            g = f["skeletons"][str(s.number)]
            assert s.joint_names == text(g["names"][()])
            assert np.array_equal(s.parents, g["parents"][()])
            assert np.array_equal(s.offsets_m, g["offsets_m"][()])
            assert np.array_equal(s.end_sites_m, g["end_sites_m"][()])
            assert np.array_equal(s.has_end_site, g["has_end_site"][()].astype(bool))
            assert s.channels == text(g["channels"][()])
            assert np.array_equal(s.segments, g["segments"][()])
            assert np.array_equal(s.masses_kg, g["mass_kg"][()])
            assert s.root_joint == g.attrs["root_joint"]
            assert s.frame_count == g.attrs["frame_count"]
            assert s.parents[0] == -1 and all(s.parents[j] < j for j in range(s.joint_count))
            assert sorted(c.number for c in s.clips) == \
                [c.number for c in index.clips if c.skeleton_number == s.number]


# Frame arrays: the index's own memory, equal to h5py's values.

def test_every_array_matches_h5py(index, index_path):
    with h5py.File(index_path, "r") as f:
        for s in index.skeletons:
            g = f["skeletons"][str(s.number)]
            for group in ("frames", "blocks16", "blocks64", "clip_bounds"):
                for spec in mocap.Index.fields(group):
                    ours = s.array(group, spec["name"])
                    if not spec["stored"]:  # derived on load: not in the file
                        assert spec["name"] not in g[group], spec["name"]
                        assert ours.shape[0] == g[group]["local_rotations"].shape[0]
                        continue
                    theirs = g[group][spec["name"]][()]
                    assert ours.dtype == theirs.dtype == np.dtype(spec["dtype"])
                    assert ours.shape == theirs.shape, (group, spec["name"])
                    assert np.array_equal(ours, theirs), (group, spec["name"])


def test_clip_arrays_are_views_of_the_index(index, index_path):
    with h5py.File(index_path, "r") as f:
        for c in (index.clips[0], index.find_clips(content="run")[-1], index.clip("131_02")):
            fr = f["skeletons"][str(c.skeleton_number)]["frames"]
            rows = slice(c.frame_start, c.frame_start + c.frame_count)
            J = c.skeleton.joint_count
            assert c.joint_positions.shape == (c.frame_count, J, 3)
            assert c.local_rotations.shape == (c.frame_count, J, 4)
            assert c.root_positions.shape == (c.frame_count, 3)
            for spec in mocap.Index.fields("frames"):
                if spec["stored"]:
                    assert np.array_equal(c.frames(spec["name"]), fr[spec["name"]][rows]), \
                        spec["name"]
                else:  # derived: a view of the skeleton's derived array
                    assert np.array_equal(c.frames(spec["name"]),
                                          c.skeleton.frames(spec["name"])[rows]), spec["name"]
            # No copy: the clip's rows are the skeleton's array, read-only.
            whole = c.skeleton.frames("joint_positions_m")
            assert np.shares_memory(c.joint_positions, whole)
            assert c.joint_positions.ctypes.data == \
                whole.ctypes.data + c.frame_start * whole.strides[0]
            assert not c.joint_positions.flags.writeable
            with pytest.raises(ValueError):
                c.joint_positions[0, 0, 0] = 1.0
            assert c.energy_prefix_J[0] == 0.0 and c.energy_prefix_J.dtype == np.float64
            # The root joint's positions are the root position array.
            assert np.array_equal(c.joint_positions[:, c.skeleton.root_joint], c.root_positions)


def test_arrays_keep_the_index_alive(index_path):
    ix = mocap.Index(index_path)
    positions = ix.clips[1].joint_positions
    expected = positions.copy()
    del ix
    gc.collect()
    assert np.array_equal(positions, expected)


def test_fields_are_documented():
    names = [f["name"] for f in mocap.Index.fields()]
    assert names[:4] == ["root_position_m", "local_rotations", "world_rotations",
                         "joint_positions_m"]
    assert all(f["unit"] and f["description"] for f in mocap.Index.fields("clip_bounds"))
    derived = [f["name"] for f in mocap.Index.fields() if not f["stored"]]
    assert derived == ["world_rotations", "segment_com_m", "segment_com_velocity_mps",
                       "segment_angular_velocity_radps", "h_scan", "kd_features"]
