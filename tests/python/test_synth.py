"""Index.synthesize: mocap-synth's job from Python, cross-checked against
mocap-synth on the same query: the same BVH, byte for byte, and the same
REPORT.json but for its timings."""
import json
import os
import subprocess

import numpy as np
import pytest

import mocap
from conftest import SOURCE_DIR, set1, tool


def example_query(data_dir):
    """docs/examples/synth-query.json on this data: stand, walk, wave."""
    with open(os.path.join(SOURCE_DIR, "docs", "examples", "synth-query.json")) as f:
        return json.loads(f.read().replace("@DATA@", data_dir))


def untimed(report):
    """A report without its times (they differ between any two runs)."""
    out = json.loads(json.dumps(report))
    out.pop("timings_ms")
    for t in out["transitions"]:
        t.pop("time_ms")
    return out


@pytest.fixture
def query_file(data_dir, scratch):
    path = os.path.join(scratch, "query.json")
    with open(path, "w") as f:
        json.dump(example_query(data_dir), f)
    return path


def mocap_synth(index_path, query_file, out, *flags):
    subprocess.run([tool("mocap-synth"), "--index", index_path, "--query", query_file,
                    "--out", out, *flags], check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        return f.read()


# Invalid inputs first.

def test_invalid_options(index, data_dir):
    q = example_query(data_dir)
    with pytest.raises(mocap.InputError, match="expected astar, slerp or inertialize"):
        index.synthesize(q, method="spline")
    with pytest.raises(mocap.InputError, match="expected PAIR:RANK"):
        index.synthesize(q, picks=["1-2"])
    with pytest.raises(mocap.InputError, match="pair 5 out of range"):
        index.synthesize(q, picks=[(5, 1)])
    with pytest.raises(mocap.InputError, match="max_states"):
        index.synthesize(q, max_states=0)
    with pytest.raises(mocap.InputError, match="refine_smoothing_J"):
        index.synthesize(q, refine=4, refine_smoothing_J=-1.0)
    with pytest.raises(mocap.InputError, match="fps"):
        index.synthesize(q, fps=0.0)
    with pytest.raises(mocap.InputError, match="expected g or w"):
        index.synthesize(q, energy="work")
    bad = dict(q, frames=q["frames"][:1] + [{"joints": {"NoSuchJoint": {"quat": [1, 0, 0, 0]}}}])
    with pytest.raises(mocap.InputError, match="unknown joint"):
        index.synthesize(bad)
    with pytest.raises(mocap.InputError, match="needs a timed query"):
        index.synthesize(q, warp=True)
    with pytest.raises(mocap.InputError, match="warp_candidates"):
        index.synthesize(q, warp_candidates=0)
    for bad in (-1e-4, float("inf"), float("nan")):
        with pytest.raises(mocap.InputError, match="warp_work_weight_m_per_J"):
            index.synthesize(q, warp_work_weight_m_per_J=bad)
    other = index.search(dict(q, id="another-query"))
    with pytest.raises(mocap.InputError, match="no results for query"):
        index.synthesize(q, results=other)


# The cross-check with mocap-synth.

def test_same_motion_and_report_as_mocap_synth(index, index_path, query_file, scratch):
    out = os.path.join(scratch, "m.bvh")
    report_file = os.path.join(scratch, "r.json")
    theirs = mocap_synth(index_path, query_file, out, "--report", report_file)
    with open(query_file) as f:
        query = json.load(f)
    motion = index.synthesize(query, base_dir=scratch)
    assert motion.bvh() == theirs
    with open(report_file) as f:
        their_report = json.load(f)
    ours = motion.report(query_file=query_file, bvh_path=out)
    assert untimed(ours) == untimed(their_report)
    # write_bvh writes the same file.
    mine = os.path.join(scratch, "mine.bvh")
    motion.write_bvh(mine)
    with open(mine) as f:
        assert f.read() == theirs


def test_given_results_and_picks_as_mocap_synth(index, index_path, query_file, scratch):
    results_file = os.path.join(scratch, "results.jsonl")
    subprocess.run([tool("mocap-search"), "--index", index_path, "--query", query_file,
                    "--out", results_file, "-q"], check=True)
    out = os.path.join(scratch, "m.bvh")
    theirs = mocap_synth(index_path, query_file, out, "--results", results_file,
                         "--pick", "1:2", "--transition", "slerp")
    with open(query_file) as f:
        query = json.load(f)
    # The results as a file, and as the dict Index.search gives.
    by_file = index.synthesize(query, results=results_file, picks=["1:2"], method="slerp")
    by_dict = index.synthesize(query, results=index.search(query), picks=[(1, 2)],
                               method="slerp")
    assert by_file.bvh() == by_dict.bvh() == theirs
    assert by_file.chosen[0]["rank"] == 2
    assert by_file.report()["timings_ms"]["search"] == 0.0


def test_search_energy_as_mocap_synth(index, index_path, query_file, scratch):
    out = os.path.join(scratch, "g.bvh")
    theirs = mocap_synth(index_path, query_file, out, "--energy", "g", "--step-feet")
    with open(query_file) as f:
        query = json.load(f)
    motion = index.synthesize(query, base_dir=scratch, energy="g", step_feet=True)
    assert motion.bvh() == theirs
    params = motion.report()["parameters"]
    assert params["energy"] == "g" and params["step_feet"] is True
    # The defaults, as mocap-synth's: W, no stepping pass.
    default = index.synthesize(query, base_dir=scratch).report()["parameters"]
    assert default["energy"] == "w" and default["step_feet"] is False


def test_timed_pairs_are_warped_by_default_as_mocap_synth(index, index_path, data_dir, scratch):
    walk = os.path.join(data_dir, "bandai-namco-1", "data", "dataset-1_walk_normal_001.bvh")
    query = {"id": "ib", "frames": [{"bvh": walk, "frame": 100, "time_s": 0},
                                    {"bvh": walk, "frame": 131, "time_s": 31 / 30}],
             "filter": {"exclude": ["dataset-1_walk_normal_001*"]}}
    query_file = os.path.join(scratch, "timed.json")
    with open(query_file, "w") as f:
        json.dump(query, f)
    for flags, kwargs, warped in (([], {}, True), (["--warp"], {"warp": True}, True),
                                  (["--no-warp"], {"warp": False}, False),
                                  (["--warp-candidates", "1"], {"warp_candidates": 1}, True),
                                  (["--warp-work-weight", "0"],
                                   {"warp_work_weight_m_per_J": 0.0}, True)):
        theirs = mocap_synth(index_path, query_file, os.path.join(scratch, "t.bvh"), *flags)
        motion = index.synthesize(query, **kwargs)
        assert motion.bvh() == theirs, flags
        report = motion.report()
        assert report["timing"]["pairs"][0]["warped"] is warped, flags
        assert report["parameters"]["warp"] is warped, flags
        if warped:
            assert report["timing"]["pairs"][0]["warp_candidates"] == kwargs.get(
                "warp_candidates", 5), flags
            assert report["timing"]["pairs"][0]["warp_work_J"] > 0, flags
            assert report["parameters"]["warp_work_weight_m_per_J"] == kwargs.get(
                "warp_work_weight_m_per_J", 3e-4), flags


# The motion as arrays.

def test_motion_arrays(index, data_dir):
    motion = index.synthesize(example_query(data_dir))
    report = motion.report()
    F, J = motion.frame_count, len(motion.joint_names)
    assert F == report["motion"]["frames"] > 10
    assert motion.frame_time_s == report["motion"]["frame_time_s"]
    skeleton = index.skeletons[motion.skeleton]
    assert motion.joint_names == skeleton.joint_names
    assert np.array_equal(motion.parents, skeleton.parents)
    assert motion.root_positions.shape == (F, 3)
    assert motion.joint_positions.shape == (F, J, 3)
    assert motion.local_rotations.shape == motion.world_rotations.shape == (F, J, 4)
    assert np.allclose(np.linalg.norm(motion.local_rotations, axis=2), 1.0)
    assert np.allclose(motion.joint_positions[:, motion.root_joint], motion.root_positions,
                       atol=1e-12)
    assert motion.step_energies_J.tolist() == report["motion"]["step_energies_J"]
    assert [s["kind"] for s in motion.segments] == \
        [s["kind"] for s in report["motion"]["segments"]]
    assert sum(s["frames"] for s in motion.segments) == F
    assert [c["clip"] for c in motion.chosen] == [c["clip"] for c in report["chosen"]]
    # The query's first frame is where the motion starts: frame 20 of the walk.
    walk = index.clip(os.path.basename(set1("dataset-1_walk_normal_001")))
    assert np.allclose(motion.joint_positions[0], walk.joint_positions[20], atol=1e-5)
    # The BVH of the motion poses the same joints (file units: centimetres).
    bvh = motion.to_bvh()
    assert bvh.frame_count == F and bvh.joint_names == motion.joint_names
    assert np.allclose(bvh.joint_positions(unit=walk.unit), motion.joint_positions, atol=1e-6)
    assert "data-figure" in motion.report_html()


def test_write_by_extension(index, data_dir, scratch):
    # write(path) as mocap-synth --out: .npz arrays equal the motion's own
    # world positions, .glb is glTF binary, anything else the BVH write_bvh writes.
    motion = index.synthesize(example_query(data_dir))
    npz, glb, bvh = (os.path.join(scratch, "m." + e) for e in ("npz", "glb", "bvh"))
    motion.write(npz)
    motion.write(glb)
    motion.write(bvh)
    with np.load(npz) as z:
        names = [str(n) for n in z["names"]]
        assert z["positions"].shape == (motion.frame_count, len(names), 3)
        assert abs(float(z["fps"]) - 1.0 / motion.frame_time_s) < 1e-9
        for j, name in enumerate(motion.joint_names):
            k = names.index(name)
            assert np.allclose(z["positions"][:, k], motion.joint_positions[:, j], atol=1e-4), name
    with open(glb, "rb") as f:
        assert f.read(4) == b"glTF"
    with open(bvh, encoding="utf-8") as f:
        assert f.read() == motion.bvh()
