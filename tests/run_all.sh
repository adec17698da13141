#!/usr/bin/env bash
# Runs every test of the project: the Rust workspace tests, then the Python
# tests that check naic against implementations no one here wrote (Pinocchio,
# MuJoCo, rclpy on ROS 2 Jazzy, mcap-ros2-support, rosbags).
#
# It creates its own Python venv (default .venv; set NAIC_VENV to reuse one)
# and installs tests/requirements.txt into it. DDS traffic stays on loopback.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

# Each stage prints when it starts and how long the run has taken so far, so a slow
# or stuck stage can be told from the log alone.
started=$SECONDS
stage() { echo "== $* ($(date -u +%H:%M:%S) UTC, $((SECONDS - started)) s in)"; }

venv=${NAIC_VENV:-$root/.venv}
if [ ! -x "$venv/bin/python" ]; then
    echo "== creating Python venv $venv"
    python3 -m venv "$venv"
fi
stamp="$venv/.naic-requirements.sha256"
want=$(sha256sum tests/requirements.txt | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
    echo "== installing tests/requirements.txt into $venv"
    "$venv/bin/pip" install -q --upgrade pip
    "$venv/bin/pip" install -q -r tests/requirements.txt
    echo "$want" > "$stamp"
fi
export NAIC_VENV=$venv
export NAIC_PYTHON=$venv/bin/python

# Keep every DDS participant of the tests on this machine.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_LOCALHOST_ONLY=1

# MuJoCo as a plant (`--features mujoco`, docs/simulation.md): link the libmujoco of the
# venv's `mujoco` wheel. mujoco-rs wants a folder with `libmujoco.so`; the wheel ships
# only `libmujoco.so.<version>`, so the links go in a build folder (target/mujoco-lib),
# not into the venv, and the library path is set for the test binaries and naic.
mj_dir=$("$venv/bin/python" -c "import mujoco, os; print(os.path.dirname(mujoco.__file__))")
mj_ver=$("$venv/bin/python" -c "import mujoco; print(mujoco.__version__)")
if [ ! -f "$mj_dir/libmujoco.so.$mj_ver" ]; then
    echo "run_all.sh: the mujoco wheel in $venv has no libmujoco.so.$mj_ver" >&2
    exit 1
fi
mkdir -p "$root/target/mujoco-lib"
ln -sf "$mj_dir/libmujoco.so.$mj_ver" "$root/target/mujoco-lib/libmujoco.so"
ln -sf "$mj_dir/libmujoco.so.$mj_ver" "$root/target/mujoco-lib/libmujoco.so.$mj_ver"
export MUJOCO_DYNAMIC_LINK_DIR=$root/target/mujoco-lib
export LD_LIBRARY_PATH=$root/target/mujoco-lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
features=naic/mujoco,naic_sim/mujoco,jk5_sim_driver/mujoco
export NAIC_CARGO_FEATURES=$features

stage "building (release, features $features)"
cargo build --release --workspace --all-targets --features "$features"

stage "Rust tests"
cargo test --release --workspace --features "$features"

# DDS Security (naic_ros/security, docs/deploy.md "Who may move the arm") links the system
# OpenSSL: libssl-dev and pkg-config. Built into its own target directory, so the binaries
# above stay as they are; tests/python/test_ros_security.py uses these.
if ! pkg-config --exists openssl 2>/dev/null; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        apt-get update -q && apt-get install -y -q libssl-dev pkg-config
    else
        echo "run_all.sh: DDS Security needs libssl-dev and pkg-config (apt-get install -y libssl-dev pkg-config)" >&2
        exit 1
    fi
fi
stage "building with DDS Security (target/security)"
CARGO_TARGET_DIR="$root/target/security" cargo build --release --workspace --bins --features naic_ros/security
CARGO_TARGET_DIR="$root/target/security" cargo test --release -p naic_ros --features security security

stage "Python cross-checks"
# A test that hangs fails after its timeout (pytest-timeout, SIGALRM: the run goes on
# with the next test) instead of holding the whole run; the slowest tests are listed.
# The run as a whole keeps within NAIC_CI_BUDGET seconds (CI allows 5400): no new test
# starts once the budget less one test's timeout and a margin is spent, so a slow
# machine gets a failing run with its summary rather than one killed without it.
budget=${NAIC_CI_BUDGET:-5400}
left=$((budget - (SECONDS - started) - 420 - 120))
if [ "$left" -lt 60 ]; then left=60; fi
"$venv/bin/python" -m pytest -q -rfE --durations=25 --timeout=420 --session-timeout="$left" tests/python
stage "done"
