"""Index.style_model and mocap.recognise_style (docs/style.md): bad input
raises mocap.InputError naming the file; the model is the one mocap-index
style-model writes and the recognition what mocap-search style --json
prints (same fields, same numbers), from a model dict or a model file."""
import json
import os
import subprocess

import pytest

import mocap
from conftest import set1, tool


def test_bad_input_raises_input_error(index, data_dir):
    model = index.style_model()
    cmu = os.path.join(data_dir, "cmu", "131_01.bvh")
    with pytest.raises(mocap.InputError, match='no joint "Spine"') as e:
        mocap.recognise_style(model, cmu)
    assert e.value.source == cmu
    with pytest.raises(mocap.InputError, match="outside the clip"):
        mocap.recognise_style(model, set1("dataset-1_walk_old_001"), frames=(10, 99999))
    with pytest.raises(mocap.InputError, match="at least 4"):
        mocap.recognise_style(model, set1("dataset-1_walk_old_001"), frames=(10, 11))
    with pytest.raises(mocap.InputError, match="no content"):
        mocap.recognise_style(model, set1("dataset-1_walk_old_001"), content="swim")


def test_same_model_and_answers_as_the_commands(index, index_path, scratch):
    model, evaluation = index.style_model(evaluate=True)
    path = os.path.join(scratch, "style.json")
    subprocess.run([tool("mocap-index"), "style-model", index_path, "--out", path], check=True,
                   stdout=subprocess.DEVNULL)
    with open(path) as f:
        assert json.load(f) == model
    assert evaluation["takes"] + evaluation["alone"] == model["clips"]
    assert 0.0 <= evaluation["accuracy"] <= 1.0
    take = set1("dataset-1_run_tired_001")
    ours = mocap.recognise_style(model, take, frames=(5, 40))
    theirs = json.loads(subprocess.run(
        [tool("mocap-search"), "style", "--model", path, take + ":5-40", "--json"], check=True,
        capture_output=True, text=True).stdout)
    assert ours == theirs
    assert mocap.recognise_style(path, take, frames=(5, 40)) == ours
    assert ours["frames"] == [5, 40]
    assert ours["style"] == max(ours["probabilities"], key=ours["probabilities"].get)
    given = mocap.recognise_style(model, take, content="run")
    assert given["content"] == "run" and not given["content_recognised"]


def test_search_results_with_their_style_as_mocap_search_gives_them(index, index_path, scratch,
                                                                   data_dir):
    model = index.style_model()
    path = os.path.join(scratch, "style.json")
    with open(path, "w") as f:
        json.dump(model, f)
    walk = set1("dataset-1_walk_old_001")
    q = {"id": "oldwalk", "top": 5, "filter": {"exclude": ["dataset-1_walk_old_001*"]},
         "frames": [{"bvh": walk, "frame": 20}, {"bvh": walk, "frame": 60}]}
    ours = index.search(q, threads=1, style_model=model)
    qpath = os.path.join(scratch, "q.jsonl")
    with open(qpath, "w") as f:
        f.write(json.dumps(q) + "\n")
    out = subprocess.run([tool("mocap-search"), "--index", index_path, "--queries", qpath,
                          "--style-model", path, "--threads", "1", "-q"], check=True,
                         capture_output=True, text=True).stdout
    theirs = json.loads(out)
    for a, b in zip(ours["pairs"][0]["results"], theirs["pairs"][0]["results"]):
        assert a == b
        assert a["recognised_style"]["label"] in model["style"]["classes"]
    assert index.search(q, threads=1, style_model=path)["pairs"] == ours["pairs"]
    assert "recognised_style" not in index.search(q, threads=1)["pairs"][0]["results"][0]


def test_synthesis_reports_styles_as_mocap_synth_does(index, scratch):
    model = index.style_model()
    walk = set1("dataset-1_walk_old_001")
    q = {"id": "oldwalk", "filter": {"exclude": ["dataset-1_walk_old_001*"]},
         "frames": [{"bvh": walk, "frame": 20, "time_s": 0},
                    {"bvh": walk, "frame": 50, "time_s": 1.0}]}
    one = index.synthesize(q, style_model=model).report()
    assert [s["of"] for s in one["styles"]] == ["motion", "partial 1"]
    assert all(s["label"] in model["style"]["classes"] for s in one["styles"])
    [batch] = index.synthesize_batch([q], style_model=model)
    assert batch.report()["styles"] == one["styles"]
    assert "styles" not in index.synthesize(q).report()


def test_synthesis_of_a_query_asking_for_a_style(index):
    # The query's "style" (retrieval by style) needs the model in the search
    # that synthesize runs, alone and in a batch.
    model = index.style_model()
    walk = set1("dataset-1_walk_old_001")
    q = {"id": "ask-old", "filter": {"exclude": ["dataset-1_walk_old_001*"]},
         "style": {"label": "old", "weight": 20},
         "frames": [{"bvh": walk, "frame": 20, "time_s": 0},
                    {"bvh": walk, "frame": 50, "time_s": 1.0}]}
    with pytest.raises(mocap.InputError, match="style"):
        index.synthesize(q)
    one = index.synthesize(q, style_model=model)
    [batch] = index.synthesize_batch([q], style_model=model)
    assert batch.report()["chosen"] == one.report()["chosen"]



def test_style_transfer_as_mocap_synth_does_it(index, index_path, scratch):
    model = index.style_model()
    walk = set1("dataset-1_walk_old_001")
    q = {"id": "to-tired", "filter": {"exclude": ["dataset-1_walk_old_001*"]},
         "frames": [{"bvh": walk, "frame": 20, "time_s": 0},
                    {"bvh": walk, "frame": 50, "time_s": 1.0}]}
    with pytest.raises(mocap.InputError, match="needs style_model") as e:
        index.synthesize(q, style="tired")
    assert e.value.source == "style"
    with pytest.raises(mocap.InputError, match='no style "elderly"; its styles: active'):
        index.synthesize(q, style_model=model, style="elderly")
    one = index.synthesize(q, style_model=model, style="tired")
    report = one.report()
    assert report["style_transfer"]["style"] == "tired"
    assert [s["of"] for s in report["styles"][:2]] == ["motion", "motion before transfer"]
    # The query's "synth_style" replaces style=; the batch gives the same motion.
    [batch] = index.synthesize_batch([dict(q, synth_style="tired")], style_model=model,
                                     style="old")
    assert batch.report()["style_transfer"]["style"] == "tired"
    path = os.path.join(scratch, "style.json")
    with open(path, "w") as f:
        json.dump(model, f)
    mine, theirs = os.path.join(scratch, "mine.bvh"), os.path.join(scratch, "theirs.bvh")
    batch.write_bvh(mine)
    qpath = os.path.join(scratch, "q.json")
    with open(qpath, "w") as f:
        json.dump(q, f)
    subprocess.run([tool("mocap-synth"), "--index", index_path, "--query", qpath, "--out", theirs,
                    "--style-model", path, "--style", "tired"], check=True,
                   stdout=subprocess.DEVNULL)
    with open(mine, "rb") as a, open(theirs, "rb") as b:
        assert a.read() == b.read()
