"""Fixtures of the Python module's tests (tests/python, run by CTest as
python.<file>; docs/python.md).

Environment (CTest sets it; defaults for a run by hand from the source tree):
  MOCAP_BIN_DIR   the build folder (build/): mocap-index, mocap-search,
                  mocap-synth, and python/ holding the package mocap
  MOCAP_DATA_DIR  the real data (../shared/data); tests that need it are
                  skipped when its set 1 is absent
Each test's files go to its own temporary folder (tempfile), removed after.
"""
import glob
import os
import shutil
import subprocess
import sys
import tempfile

import pytest

SOURCE_DIR = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BIN_DIR = os.environ.get("MOCAP_BIN_DIR", os.path.join(SOURCE_DIR, "build"))
DATA_DIR = os.environ.get("MOCAP_DATA_DIR",
                          os.path.abspath(os.path.join(SOURCE_DIR, "..", "shared", "data")))
SET1 = os.path.join(DATA_DIR, "bandai-namco-1", "data")

try:
    import mocap  # noqa: F401  (PYTHONPATH=build/python)
except ImportError:
    sys.path.insert(0, os.path.join(BIN_DIR, "python"))
    import mocap  # noqa: F401


def tool(name):
    """Path of a built executable (mocap-index, mocap-search, mocap-synth)."""
    folder = {"mocap-index": "indexer", "mocap-search": "search", "mocap-synth": "synth"}[name]
    path = os.path.join(BIN_DIR, folder, name)
    if not os.access(path, os.X_OK):
        pytest.fail(f"{path} is not built")
    return path


def set1(name):
    """A set-1 file by stem (dataset-1_walk_normal_001 -> .../dataset-1_walk_normal_001.bvh)."""
    return os.path.join(SET1, name + ".bvh")


@pytest.fixture
def scratch():
    """A temporary folder of the test's own."""
    folder = tempfile.mkdtemp(prefix="mocap-pytest-")
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def data_dir():
    if not os.path.isdir(SET1):
        pytest.skip(f"no data at {DATA_DIR} (MOCAP_DATA_DIR)")
    return DATA_DIR


@pytest.fixture(scope="session")
def index_path(data_dir):
    """A small index of real data, built once per test file: set-1 walks,
    runs, bows and goodbyes (two labels each), and CMU subject 131 (another
    skeleton, 120 fps, no labels)."""
    files = []
    for content in ("walk", "run", "bow", "bye"):
        files += sorted(glob.glob(os.path.join(SET1, f"dataset-1_{content}_*.bvh")))
    files += sorted(glob.glob(os.path.join(data_dir, "cmu", "*.bvh")))
    folder = tempfile.mkdtemp(prefix="mocap-pytest-index-")
    path = os.path.join(folder, "index.h5")
    subprocess.run([tool("mocap-index"), "build", "-q", "--out", path] + files, check=True,
                   stdout=subprocess.DEVNULL)
    yield path
    shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def index(index_path):
    return mocap.Index(index_path)
