"""Index.search: query batches on the shared engine, cross-checked field by
field against mocap-search's output lines for the same queries."""
import json
import os
import subprocess

import numpy as np
import pytest

import mocap
from conftest import set1, tool


def strip_time(outcome):
    """An outcome without its time (the only field that differs between runs
    on one thread)."""
    out = json.loads(json.dumps(outcome))
    out.get("stats", {}).pop("time_ms", None)
    return out


def results(outcome):
    """An outcome's id and ranked results (on several threads, how much the
    bounds pruned depends on the order the clips finish in; the results do
    not)."""
    return {k: v for k, v in outcome.items() if k != "stats"}


def batch(data_dir):
    walk, run, bye = (set1("dataset-1_walk_normal_001"), set1("dataset-1_run_normal_001"),
                      set1("dataset-1_bye_normal_001"))
    cmu = os.path.join(data_dir, "cmu", "131_01.bvh")
    return [
        {"id": "walk", "relative": False, "top": 5,
         "frames": [{"bvh": walk, "frame": 10}, {"bvh": walk, "frame": 40},
                    {"bvh": walk, "frame": 70}]},
        {"id": "run-anywhere", "top": 4, "filter": {"exclude": ["*_run_normal_*"]},
         "frames": [{"bvh": run, "frame": 2}, {"bvh": run, "frame": 20}]},
        {"id": "arm", "relative": False, "top": 3, "filter": {"content": ["bow", "bye"]},
         "frames": [{"joints": {"RightArm": {"euler_deg": [0, 0, 80], "order": "ZXY"}}},
                    {"root_position": [0, None, 0]}]},
        {"id": 7, "top": 6, "path_weight": 0.01, "min_length_s": 0.5, "max_length_s": 2,
         "frames": [{"root_position": [0, None, 0]}, {"root_position": [0, None, 1.5]}]},
        {"id": "wave-cmu", "relative": "position", "top": 3, "transition_time": 0.3,
         "frames": [{"bvh": bye, "frame": 30, "only": ["root_position", "RightArm"]},
                    {"bvh": cmu, "frame": 200}]},
        {"id": "unknown-joint",
         "frames": [{"joints": {"Tail": {"quat": [1, 0, 0, 0]}}}, {"root_position": [0, None, 0]}]},
        {"id": "too-short", "frames": [{"root_position": [0, None, 0]}]},
    ]


@pytest.fixture
def cli(index_path):
    """Runs mocap-search on a list of queries (written as a JSONL batch) with
    more flags; returns its output lines as dicts."""
    def run(queries, folder, *flags):
        path = os.path.join(folder, "q.jsonl")
        with open(path, "w") as f:
            for q in queries:
                f.write(json.dumps(q) + "\n")
        out = os.path.join(folder, "r.jsonl")
        # Exit 1 when some queries failed (their lines carry the error).
        rc = subprocess.run([tool("mocap-search"), "--index", index_path, "--queries", path,
                             "--out", out, "-q", *flags]).returncode
        assert rc in (0, 1)
        with open(out) as f:
            return [json.loads(line) for line in f]
    return run


# Invalid inputs first.

def test_invalid_options(index):
    q = {"frames": [{"root_position": [0, None, 0]}, {"root_position": [1, None, 0]}]}
    with pytest.raises(mocap.InputError, match="expected exact, approx or brute"):
        index.search(q, mode="fast")
    with pytest.raises(mocap.InputError, match="min_length_s: 3 s must not exceed max_length_s"):
        index.search(q, min_length_s=3.0, max_length_s=1.0)
    with pytest.raises(mocap.InputError, match="min_length_s: must be a number of seconds > 0, got nan"):
        index.search(q, min_length_s=float("nan"))
    with pytest.raises(mocap.InputError, match="checks"):
        index.search(q, mode="approx", checks=0)
    with pytest.raises(TypeError, match="a query is a dict"):
        index.search([q, 3])


def test_bad_queries_fail_alone(index):
    ok = {"id": "ok", "frames": [{"root_position": [0, None, 0]}, {"root_position": [1, None, 0]}]}
    out = index.search([ok, "this is not json", {"id": "file", "frames": [
        {"bvh": "missing.bvh", "frame": 0}, {"root_position": [0, None, 0]}]}, {"frames": []}])
    assert [o["id"] for o in out] == ["ok", "query 2", "file", "query 4"]
    assert "pairs" in out[0] and "error" not in out[0]
    assert set(out[1]) == {"id", "error"} and out[1]["error"].startswith("<query 2>")
    assert "missing.bvh" in out[2]["error"]
    assert out[3]["error"].startswith("<query 4>: frames")


def test_one_bad_query_raises_like_synthesize(index):
    # One query: mocap.InputError with where and what, as synthesize raises
    # (a list gives error lines instead: test_bad_queries_fail_alone).
    cases = [("this is not json", "invalid JSON"),
             ({"id": "few", "frames": []}, "frames"),
             ({"id": "typo", "Top": 3, "frames": [{"root_position": [0, None, 0]}] * 2},
              'did you mean "top"'),
             ({"id": "joint", "frames": [{"root_position": [0, None, 0]},
                                         {"joints": {"NoSuchJoint": {"quat": [1, 0, 0, 0]}}}]},
              "unknown joint")]
    for query, what in cases:
        with pytest.raises(mocap.InputError, match=what) as e:
            index.search(query)
        assert isinstance(e.value, ValueError) and e.value.detail, query
        with pytest.raises(mocap.InputError, match=what):
            index.synthesize(query)
        assert "error" in index.search([query])[0]


def test_relative_paths_resolve_against_base_dir(index, data_dir):
    q = {"id": "rel", "relative": False, "top": 2,
         "frames": [{"bvh": "dataset-1_walk_normal_001.bvh", "frame": 10},
                    {"bvh": "dataset-1_walk_normal_001.bvh", "frame": 40}]}
    with pytest.raises(mocap.InputError, match="dataset-1_walk_normal_001.bvh"):
        index.search(q, base_dir=os.path.dirname(data_dir))
    out = index.search(q, base_dir=os.path.dirname(set1("x")))
    top = out["pairs"][0]["results"][0]
    assert top["clip"].endswith("dataset-1_walk_normal_001.bvh")
    assert (top["start_frame"], top["end_frame"]) == (10, 40) and abs(top["score_J"]) < 1e-6


# The cross-check: the same lines as mocap-search.

@pytest.mark.parametrize("mode", ["exact", "brute"])
def test_same_lines_as_mocap_search(index, data_dir, scratch, cli, mode):
    queries = batch(data_dir)
    theirs = cli(queries, scratch, "--mode", mode, "--threads", "1")
    ours = index.search(queries, mode=mode, threads=1)
    assert len(ours) == len(theirs) == len(queries)
    for q, a, b in zip(queries, ours, theirs):
        assert list(a) == list(b), q["id"]  # the same fields, in the same order
        if "error" in b:
            # The same message, but for where the query came from.
            assert a["error"].split(": ", 1)[1] == b["error"].split(": ", 1)[1], q["id"]
            continue
        assert strip_time(a) == strip_time(b), q["id"]
        assert a["pairs"] and all(p["results"] for p in a["pairs"]), q["id"]
    assert [o["id"] for o in ours] == ["walk", "run-anywhere", "arm", "7", "wave-cmu",
                                       "unknown-joint", "too-short"]
    assert "unknown joint" in ours[5]["error"]


def test_options_match_mocap_search(index, data_dir, scratch, cli):
    queries = batch(data_dir)[:4]
    theirs = cli(queries, scratch, "--min-length", "0.4", "--max-length", "3")
    ours = index.search(queries, min_length_s=0.4, max_length_s=3.0)
    assert [results(o) for o in ours] == [results(o) for o in theirs]
    # approx: the same candidates and results, and the same recall.
    approx_cli = cli(queries, scratch, "--mode", "approx", "--checks", "64")
    approx = index.search(queries, mode="approx", checks=64)
    assert [results(o) for o in approx] == [results(o) for o in approx_cli]
    assert [o["stats"]["recall"] for o in approx] == [o["stats"]["recall"] for o in approx_cli]


def test_one_query_in_one_dict_out(index, data_dir):
    q = batch(data_dir)[0]
    one = index.search(q)
    assert isinstance(one, dict) and results(one) == results(index.search([q])[0])
    top = one["pairs"][0]["results"][0]
    assert top["clip"].endswith("dataset-1_walk_normal_001.bvh")
    assert (top["start_frame"], top["end_frame"]) == (10, 40)
    # A result names its clip: its frames are that clip's rows.
    clip = index.clips[top["clip_index"]]
    assert clip.path == top["clip"] and clip.labels == top["labels"]
    # JSON text in, and numpy numbers in a dict, are the same query.
    assert results(index.search(json.dumps(q))) == results(one)
    numeric = {"id": "np", "relative": False, "top": 3,
               "frames": [{"root_position": np.array([0.0, np.nan, 0.0]).tolist()},
                          {"root_position": [np.float64(1.0), None, np.float32(0.5)]}]}
    numeric["frames"][0]["root_position"][1] = None
    plain = json.loads(json.dumps(numeric, default=float))
    assert results(index.search(numeric)) == results(index.search(plain))


def test_context_frames_as_mocap_search_gives_them(index, scratch, cli):
    walk = set1("dataset-1_walk_normal_001")
    q = {"id": "ctx", "top": 3, "filter": {"exclude": ["*_walk_normal_001*"]},
         "frames": [{"bvh": walk, "frame": 20, "context": {"before": 5}},
                    {"bvh": walk, "frame": 50, "context": {"after": 3, "weight": 2}}]}
    ours = index.search(q, threads=1)
    assert strip_time(ours) == strip_time(cli([q], scratch, "--threads", "1")[0])
    for r in ours["pairs"][0]["results"]:
        assert r["context_in_J"] > 0 and r["context_out_J"] > 0
    plain = dict(q, frames=[{k: v for k, v in f.items() if k != "context"} for f in q["frames"]])
    assert "context_in_J" not in index.search(plain)["pairs"][0]["results"][0]
