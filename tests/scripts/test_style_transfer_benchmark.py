"""scripts/style-transfer-benchmark's pieces: a held-out cell's takes stay
out of the training folder (their label sidecars too), the key-pose query
of a take, the judge's style space, the summary's counts; and
scripts/style-transfer-figure's forward kinematics and SVG."""
import importlib.util
import json
import os
from importlib.machinery import SourceFileLoader

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts")


def load(name):
    loader = SourceFileLoader(name.replace("-", "_"), os.path.join(SCRIPTS, name))
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(module)
    return module


def bvh(frames, leg_y=-40):
    rows = "\n".join(" ".join(str(v) for v in row) for row in frames)
    return ("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition "
            "Zrotation Xrotation Yrotation\n  JOINT Leg\n  {\n"
            f"    OFFSET 0 {leg_y} 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
            "    End Site\n    {\n      OFFSET 0 -1 0\n    }\n  }\n}\nMOTION\n"
            f"Frames: {len(frames)}\nFrame Time: 0.0333333\n{rows}\n")


def test_a_held_out_cell_stays_out_of_the_training_folder(tmp_path):
    bench = load("style-transfer-benchmark")
    data = tmp_path / "data"
    data.mkdir()
    for name in ("walk_old_001", "walk_old_002", "walk_sad_001", "walk_sad_002", "run_old_001"):
        (data / f"dataset-1_{name}.bvh").write_text(bvh([[0] * 9]))
        (data / f"dataset-1_{name}.json").write_text("{}")
    out = tmp_path / "train"
    assert bench.training_folder(str(data), [("walk", "old")], 0, str(out)) == 3
    assert sorted(os.listdir(out)) == sorted(
        f"dataset-1_{n}.{e}" for n in ("walk_sad_001", "walk_sad_002", "run_old_001")
        for e in ("bvh", "json"))
    # At most one take a cell.
    assert bench.training_folder(str(data), [("walk", "old")], 1, str(tmp_path / "one")) == 2
    assert bench.cell_of("dataset-2_wave-right-hand_feminine_003.bvh") == (
        "wave-right-hand", "feminine")


def test_the_key_pose_query_takes_frames_at_their_own_times(tmp_path):
    bench = load("style-transfer-benchmark")
    take = tmp_path / "dataset-1_walk_old_001.bvh"
    take.write_text(bvh([[0] * 9] * 100))
    q = bench.key_pose_query(str(take), "walk", "q")
    assert [f["frame"] for f in q["frames"]] == [10, 50, 90]
    assert [f["time_s"] for f in q["frames"]] == [0.0, round(40 * 0.0333333, 6),
                                                  round(80 * 0.0333333, 6)]
    assert q["filter"] == {"content": ["walk"]}
    json.dumps(q)


def test_the_style_space_and_the_summary():
    bench = load("style-transfer-benchmark")
    judge = {"content": {"classes": ["run", "walk"]}, "content_mean": [[9, 9], [1, 2]],
             "content_sd": [[1, 1], [2, 4]], "style_scale": [0.5, 2]}
    assert bench.style_space(judge, [5, 2], "walk") == [4.0, 0.0]
    row = lambda style, plain, moved: {  # noqa: E731
        "style": "old", "plain": {"style": plain, "p": 0.2, "distance": 3.0, "skating": 0.1,
                                  "w_J": 10.0},
        "transferred": {"style": style, "p": 0.6, "distance": moved, "skating": 0.115,
                        "w_J": 12.0}}
    s = bench.summary([row("old", "sad", 2.0), row("sad", "old", 4.0)])
    assert (s["recognised_plain"], s["recognised"], s["closer"]) == (0.5, 0.5, 0.5)
    assert s["skating_kept"] == 0.0  # 0.115 > 0.1 + 0.01
    assert (s["p_plain"], s["p"], s["w_J"]) == (0.2, 0.6, 12.0)


def test_the_figure_poses_by_forward_kinematics_and_writes_svg(tmp_path):
    fig = load("style-transfer-figure")
    (tmp_path / "a.bvh").write_text(bvh([[0, 90, 0, 0, 0, 0, 0, 0, 0],
                                         [10, 90, 0, 90, 0, 0, 0, 0, 0]]))
    (tmp_path / "b.bvh").write_text(bvh([[0, 90, 0, 0, 0, 0, 0, 0, 0],
                                         [10, 90, 0, 0, 0, 0, 0, 0, 0]]))
    a = fig.read_bvh(str(tmp_path / "a.bvh"))
    assert a[0] == ["Hips", "Leg"] and a[1] == [-1, 0]
    hips, leg = fig.pose(a, a[4][1])
    assert [round(v, 6) for v in hips] == [10, 90, 0]
    # The hips' Zrotation 90 turns the leg's offset (0, -40, 0) onto +X.
    assert [round(v, 6) for v in leg] == [50, 90, 0]
    fig.svg(a, fig.read_bvh(str(tmp_path / "b.bvh")), str(tmp_path / "x.svg"), 2, "t")
    text = (tmp_path / "x.svg").read_text()
    assert text.startswith("<svg") and text.count("<line") == 4
