"""The installed package: `cmake --install BUILD --component python --prefix P`
puts mocap under P/MOCAP_PYTHON_INSTALL_DIR, importable from there alone."""
import os
import re
import shutil
import subprocess
import sys

import pytest

from conftest import BIN_DIR, SOURCE_DIR


def cache_value(name):
    with open(os.path.join(BIN_DIR, "CMakeCache.txt")) as f:
        for line in f:
            m = re.match(rf"{name}:\w+=(.*)", line.rstrip("\n"))
            if m:
                return m.group(1)
    pytest.fail(f"{name} is not in {BIN_DIR}/CMakeCache.txt")


def test_installed_package_imports_and_works(scratch):
    cmake = shutil.which("cmake")
    if cmake is None:
        pytest.skip("no cmake on PATH")
    prefix = os.path.join(scratch, "prefix")
    subprocess.run([cmake, "--install", BIN_DIR, "--component", "python", "--prefix", prefix],
                   check=True, stdout=subprocess.DEVNULL)
    site = os.path.join(prefix, cache_value("MOCAP_PYTHON_INSTALL_DIR"))
    files = sorted(os.listdir(os.path.join(site, "mocap")))
    assert "__init__.py" in files and any(f.startswith("_mocap") and f.endswith(".so")
                                          for f in files)
    golden = os.path.join(SOURCE_DIR, "tests", "data", "index", "golden_walk_normal_001.bvh")
    script = (
        "import mocap, os, sys\n"
        "assert mocap.__file__.startswith(sys.argv[1]), mocap.__file__\n"
        "bvh = mocap.read_bvh(sys.argv[2])\n"
        "assert bvh.joint_positions('cm').shape == (bvh.frame_count, len(bvh.joint_names), 3)\n"
        "print(mocap.__version__)\n")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = site
    out = subprocess.run([sys.executable, "-c", script, site, golden], env=env, cwd=scratch,
                         check=True, capture_output=True, text=True)
    assert re.fullmatch(r"\d+\.\d+\.\d+\n", out.stdout), out.stdout
