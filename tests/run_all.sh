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

echo "== building (release)"
cargo build --release --workspace --all-targets

echo "== Rust tests"
cargo test --release --workspace

echo "== Python cross-checks"
"$venv/bin/python" -m pytest -q tests/python
