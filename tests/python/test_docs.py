"""The Python code of docs/python.md and the README runs: every ```python
block, in order, in one namespace, in a folder laid out as the walkthrough
expects (set1.h5 in the current folder, the data at ../shared/data), on the
test index."""
import contextlib
import importlib.util
import os
import re

import numpy as np
import pytest

import mocap
from conftest import SOURCE_DIR


def blocks(page):
    with open(os.path.join(SOURCE_DIR, page)) as f:
        return re.findall(r"```python\n(.*?)```", f.read(), re.S)


@pytest.fixture
def work(index_path, data_dir, scratch, monkeypatch):
    """The current folder: the index as set1.h5 and INDEX.h5, ../shared/data."""
    folder = os.path.join(scratch, "mocap")
    os.makedirs(os.path.join(scratch, "shared"))
    os.makedirs(folder)
    os.symlink(data_dir, os.path.join(scratch, "shared", "data"))
    for name in ("set1.h5", "INDEX.h5"):
        os.symlink(index_path, os.path.join(folder, name))
    monkeypatch.chdir(folder)
    return folder


def test_readme_example_runs(work):
    (code,) = blocks("README.md")
    namespace = {}
    exec(compile(code, "README.md", "exec"), namespace)
    assert namespace["positions"].ndim == 3 and namespace["positions"].shape[2] == 3
    assert mocap.read_bvh(os.path.join(work, "step.bvh")).frame_count > 10


def test_walkthrough_runs(work, monkeypatch, capsys):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    have_matplotlib = importlib.util.find_spec("matplotlib") is not None
    code = blocks(os.path.join("docs", "python.md"))
    assert len(code) >= 8
    namespace = {}
    skipped = 0
    for block in code:
        if "matplotlib" in block and not have_matplotlib:
            skipped += 1
            continue
        with warnings_about_agg():
            exec(compile(block, "docs/python.md", "exec"), namespace)
    # What the walkthrough promised.
    assert namespace["positions"].shape == (namespace["clip"].frame_count,
                                            len(namespace["names"]), 3)
    assert namespace["answer"]["id"] == "walk-then-wave" and "error" not in namespace["answer"]
    best = namespace["best"]
    assert namespace["piece"].shape[0] == best["end_frame"] - best["start_frame"] + 1
    for name in ("walk-then-wave.bvh", "best-piece.bvh", "copy.bvh"):
        assert os.path.getsize(os.path.join(work, name)) > 1000, name
    part = namespace["part"]
    assert part.frame_count == namespace["piece"].shape[0]
    assert np.allclose(part.joint_positions(namespace["source"].detect_unit()),
                       namespace["piece"], atol=1e-5)
    assert "walk-then-wave" in capsys.readouterr().out
    if skipped:
        pytest.skip(f"{skipped} block(s) need matplotlib (scripts/setup --extra installs it)")


@contextlib.contextmanager
def warnings_about_agg():
    """plt.show() under the Agg backend warns that it shows nothing."""
    import warnings
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*non-interactive.*")
        yield
