"""Index.synthesize_batch: mocap-synth --queries from Python. Invalid
keywords first; then each item equals Index.synthesize of its query alone
(the same BVH text), a bad query's item is its mocap.InputError (returned,
not raised), threads=1 equals threads=2, and results given as search()
dicts give the motions of the search run here."""
import pytest

import mocap
from conftest import set1


def two_frames(qid, stem, a, b, times=None):
    frames = [{"bvh": set1(stem), "frame": a}, {"bvh": set1(stem), "frame": b}]
    if times:
        for f, t in zip(frames, times):
            f["time_s"] = t
    return {"id": qid, "top": 5, "frames": frames, "filter": {"exclude": [stem + "*"]}}


@pytest.fixture
def batch(data_dir):
    return [
        two_frames("walk", "dataset-1_walk_normal_001", 20, 70),
        {"id": "bad", "frames": [{"joints": {"NoSuchJoint": {"quat": [1, 0, 0, 0]}}},
                                 {"root_position": [1, 0.9, 0]}]},
        two_frames("timed", "dataset-1_bye_normal_001", 10, 40, times=(0.0, 1.0)),
        "{not json",
    ]


def test_invalid_keywords(index, batch):
    with pytest.raises(mocap.InputError, match="expected astar, slerp or inertialize"):
        index.synthesize_batch(batch, method="spline")
    with pytest.raises(mocap.InputError, match="threads"):
        index.synthesize_batch(batch, threads=-1)
    with pytest.raises(TypeError):
        index.synthesize_batch(batch, picks=["1:2"])
    with pytest.raises(TypeError, match="a list of queries"):
        index.synthesize_batch(batch[0])
    with pytest.raises(mocap.InputError, match="cannot read the search results"):
        index.synthesize_batch(batch, results="/nonexistent/results.jsonl")


def test_items_equal_single_runs(index, batch):
    made = index.synthesize_batch(batch, threads=2)
    assert len(made) == 4
    for i in (0, 2):
        assert isinstance(made[i], mocap.Synthesis)
        assert made[i].bvh() == index.synthesize(batch[i]).bvh()
        assert made[i].query_id == batch[i]["id"]
    assert isinstance(made[1], mocap.InputError)
    assert "unknown joint" in str(made[1]) and made[1].source == "<query bad>"
    assert isinstance(made[3], mocap.InputError)
    assert made[3].source == "<query 4>"
    one = index.synthesize_batch(batch, threads=1)
    for i in (0, 2):
        assert one[i].bvh() == made[i].bvh()
    # The report of a batch item is a whole report.
    assert made[0].report()["query"]["id"] == "walk"


def test_results_given(index, batch):
    untimed = [batch[0]]
    found = index.search(untimed)
    made = index.synthesize_batch(untimed, results=found)
    assert made[0].bvh() == index.synthesize(batch[0]).bvh()
    other = index.synthesize_batch([dict(batch[0], id="elsewhere")], results=found)
    assert isinstance(other[0], mocap.InputError)
    assert "no results for query" in str(other[0])


def test_synthesize_takes_a_list_as_synthesize_batch(index, batch):
    # A list given to synthesize is the batch call: the same items, in order.
    listed = index.synthesize(batch[:2], threads=1)
    made = index.synthesize_batch(batch[:2], threads=1)
    assert len(listed) == 2 and isinstance(listed[0], mocap.Synthesis)
    assert listed[0].bvh() == made[0].bvh()
    assert isinstance(listed[1], mocap.InputError) and "unknown joint" in str(listed[1])
    with pytest.raises(TypeError, match="picks name one query"):
        index.synthesize(batch[:2], picks=[(1, 2)])
