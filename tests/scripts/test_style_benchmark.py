"""scripts/style-benchmark's within-performer chance: performers told apart
by their files' OFFSET lines, each naming its most frequent style."""
import importlib.util
import os
from importlib.machinery import SourceFileLoader

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts")


def bvh(offset):
    return ("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n"
            f"  JOINT Leg\n  {{\n    OFFSET 0 {offset} 0\n    CHANNELS 3 Zrotation Xrotation "
            "Yrotation\n    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\nMOTION\n"
            "Frames: 1\nFrame Time: 0.0333333\n0 0 0 0 0 0\n")


def test_within_performer_chance(tmp_path):
    loader = SourceFileLoader("style_benchmark", os.path.join(SCRIPTS, "style-benchmark"))
    bench = importlib.util.module_from_spec(importlib.util.spec_from_loader(loader.name, loader))
    loader.exec_module(bench)
    takes = {"walk_old_001": -40, "walk_old_002": -40, "run_tired_001": -40,  # one performer
             "walk_happy_001": -45, "run_sad_001": -45}                       # another
    for name, offset in takes.items():
        (tmp_path / f"dataset-1_{name}.bvh").write_text(bvh(offset))
    (tmp_path / "dataset-1_walk_old_001.json").write_text("{}")  # not a take
    chance, performers = bench.within_performer_chance(str(tmp_path))
    assert performers == 2
    assert chance == (2 + 1) / 5  # "old" 2 of 3; one of the other's two
    assert bench.performer(str(tmp_path / "dataset-1_walk_old_001.bvh")) == ((0, 0, 0), (0, -40, 0), (0, 1, 0))
