"""Shared fixtures for the Python cross-checks: where the repo, the shared
reference material and the release `naic` binary are."""
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared"
# Inherited by every process a test starts (they all get os.environ or a copy of it): what
# _own_processes tells a test's leftover from a `naic` the user (or another checkout's
# helper) runs beside the suite from the same target/, which the check must not kill.
RUN_MARK = f"NAIC_TEST_RUN={os.getpid()}"
os.environ["NAIC_TEST_RUN"] = str(os.getpid())


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
    # the features tests/run_all.sh built with (NAIC_CARGO_FEATURES), so this is no rebuild
    features = os.environ.get("NAIC_CARGO_FEATURES")
    extra = ["--features", features] if features else []
    subprocess.run(["cargo", "build", "--release", "-q", "--workspace", "--bins", *extra], cwd=ROOT, check=True)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "naic"


@pytest.fixture(autouse=True)
def _release_ros_domains():
    """After each test, give back the DDS domain ids it claimed (tests/ros/rostest_util.py)."""
    yield
    ru = sys.modules.get("rostest_util")
    if ru is not None and hasattr(ru, "release_domains"):
        ru.release_domains()


def _own_processes():
    """pid -> executable of the live processes started by this test run (RUN_MARK in their
    environment) from this checkout's target/ (the nodes, `naic`): a test must not leave one
    behind."""
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")).resolve()
    found = {}
    for d in pathlib.Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            exe = pathlib.Path(os.readlink(d / "exe"))
        except OSError:
            continue  # gone, or not ours to read
        if target in exe.parents and exe.parent.name == "release" and _started_here(d):
            found[int(d.name)] = exe.name
    return found


def _started_here(proc_dir):
    try:
        return RUN_MARK.encode() in (proc_dir / "environ").read_bytes().split(b"\0")
    except OSError:
        return False


@pytest.fixture(scope="module", autouse=True)
def _no_process_left_behind(request):
    """After each test file (its module fixtures torn down: some keep a launch running
    for all their tests), a node or `naic` process it started and left running (a failed
    test whose clean-up did not finish, a launcher that lost a child) is killed and the
    file's last test errors with its name. An orphaned 1 kHz chain at real-time priority
    would slow every later test of the run."""
    before = set(_own_processes())
    yield
    import signal
    import time
    left = {}
    for _ in range(50):  # processes asked to stop just now get up to 5 s to exit
        left = {p: n for p, n in _own_processes().items() if p not in before}
        if not left:
            return
        time.sleep(0.1)
    threads = {pid: _thread_states(pid) for pid in left}
    for pid in left:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    pytest.fail(f"{request.module.__name__} left processes running (killed now): {sorted(left.items())}; "
                f"their threads (name, state, CPU time [s], CPU, policy, priority): {threads}", pytrace=False)


def _thread_states(pid):
    """Each thread of `pid` as (name, state, CPU time [s], last CPU, policy, RT priority),
    from /proc: a chain that cannot stop because one real-time thread never blocks shows
    that thread in state R with the CPU time (docs/notes/2026-12-dds-test-forensics.md, "A start-up freeze")."""
    policies = {0: "other", 1: "fifo", 2: "rr", 3: "batch", 5: "idle"}
    out = []
    tick = os.sysconf("SC_CLK_TCK")
    for d in sorted(pathlib.Path(f"/proc/{pid}/task").glob("*")):
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        name = stat[stat.index("(") + 1:stat.rindex(")")]
        f = stat[stat.rindex(")") + 2:].split()  # f[0] is field 3 (state)
        cpu_s = (int(f[11]) + int(f[12])) / tick
        out.append((name, f[0], round(cpu_s, 2), int(f[36]), policies.get(int(f[38]), f[38]), int(f[37])))
    return out
