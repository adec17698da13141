"""Shared fixtures for the Python cross-checks: where the repo, the shared
reference material and the release `naic` binary are."""
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared"


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def shared():
    if not SHARED.is_dir():
        pytest.fail(f"../shared not found beside the repo (looked in {SHARED})")
    return SHARED


@pytest.fixture(scope="session")
def naic_bin():
    """Path of the release `naic` binary (built by tests/run_all.sh)."""
    subprocess.run(["cargo", "build", "--release", "-q", "--bin", "naic"], cwd=ROOT, check=True)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "naic"


@pytest.fixture(autouse=True)
def _release_ros_domains():
    """After each test, give back the DDS domain ids it claimed (tests/ros/rostest_util.py)."""
    yield
    ru = sys.modules.get("rostest_util")
    if ru is not None and hasattr(ru, "release_domains"):
        ru.release_domains()
