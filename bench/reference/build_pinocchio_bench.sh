#!/usr/bin/env bash
# Builds bench/reference/pinocchio_bench.cpp with g++ against the Pinocchio C++ headers
# and shared libraries shipped in the `pin` wheel (libpinocchio), with Eigen from
# `cmeel-eigen` and urdfdom headers from `cmeel-urdfdom-headers`. All three are in
# tests/requirements.txt, so the venv that tests/run_all.sh creates has them.
#
#   bash bench/reference/build_pinocchio_bench.sh            # build; prints the binary path
#   bash bench/reference/build_pinocchio_bench.sh --run [ARGS]  # build, then run on urdf/jk5.urdf
#
# Environment:
#   NAIC_VENV                    venv with the wheels (default: <repo>/.venv, as tests/run_all.sh)
#   NAIC_PIN_BENCH_OUT           output binary (default: <repo>/target/reference/pinocchio_bench)
#   NAIC_PIN_BENCH_HEADER_ONLY=1 drop PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION, so the algorithms
#                                are compiled here from the headers with the flags below instead
#                                of running the precompiled instantiations in libpinocchio_default.so
#
# Flags: g++ -std=c++17 -O3 -DNDEBUG (no -march=native: the wheel's libraries and the Rust
# release build both target generic x86-64), plus the compile definitions that the wheel's
# CMake config files give the targets used (pinocchio::pinocchio_headers, _default, _parsers
# and coal::coal), read from those files at build time.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
venv=${NAIC_VENV:-$root/.venv}
out=${NAIC_PIN_BENCH_OUT:-$root/target/reference/pinocchio_bench}

die() {
    echo "build_pinocchio_bench: $*" >&2
    exit 1
}

[ -x "$venv/bin/python" ] || die "no Python venv at $venv (set NAIC_VENV, or create it with: bash tests/run_all.sh, or python3 -m venv $venv && $venv/bin/pip install -r tests/requirements.txt)"
command -v g++ >/dev/null || die "g++ not found (apt-get install g++)"

site=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
prefix=$site/cmeel.prefix
[ -d "$prefix" ] || die "no cmeel prefix at $prefix: install the wheels with $venv/bin/pip install -r $root/tests/requirements.txt"

need() {  # need FILE PIP-PACKAGE
    [ -e "$prefix/$1" ] || die "$prefix/$1 not found: it comes from the pip package '$2'. Fix: $venv/bin/pip install -r $root/tests/requirements.txt (or: $venv/bin/pip install $2)"
}
need include/pinocchio/algorithm/rnea.hpp "pin"
need lib/libpinocchio_default.so "pin"
need lib/libpinocchio_parsers.so "pin"
need lib/cmake/pinocchio/pinocchioTargets.cmake "pin"
need lib/cmake/coal/coalTargets.cmake "coal"
need include/eigen3/Eigen/Core "cmeel-eigen"
need include/urdfdom_headers/urdf_model/model.h "cmeel-urdfdom-headers"
need include/urdfdom/urdf_parser/urdf_parser.h "cmeel-urdfdom"

# Compile definitions from the CMake config files of the wheel.
defs=$("$venv/bin/python" - "$prefix" "${NAIC_PIN_BENCH_HEADER_ONLY:-0}" <<'EOF'
import re, sys, pathlib
prefix, header_only = pathlib.Path(sys.argv[1]), sys.argv[2] == "1"

def target_defs(path, target):
    text = path.read_text()
    m = re.search(r"set_target_properties\(%s PROPERTIES(.*?)\n\)" % re.escape(target), text, re.S)
    if m is None:
        sys.exit(f"build_pinocchio_bench: target {target} not found in {path}")
    d = re.search(r'INTERFACE_COMPILE_DEFINITIONS "([^"]*)"', m.group(1))
    return d.group(1).split(";") if d else []

pin = prefix / "lib/cmake/pinocchio/pinocchioTargets.cmake"
coal = prefix / "lib/cmake/coal/coalTargets.cmake"
out = []
for t in ("pinocchio::pinocchio_headers", "pinocchio::pinocchio_default", "pinocchio::pinocchio_parsers"):
    for d in target_defs(pin, t):
        if d == r"\$<TARGET_PROPERTY:coal::coal,INTERFACE_COMPILE_DEFINITIONS>":
            out += target_defs(coal, "coal::coal")
        elif d.startswith("$") or d.startswith("\\$"):
            sys.exit(f"build_pinocchio_bench: unexpected generator expression {d!r} in {pin}")
        elif d:
            out.append(d)
if header_only:
    out = [d for d in out if d != "PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION"]
seen = []
for d in out:
    if d not in seen:
        seen.append(d)
print(" ".join("-D" + d for d in seen))
EOF
) || die "could not read the compile definitions from $prefix/lib/cmake"

flags=(-std=c++17 -O3 -DNDEBUG)
mkdir -p "$(dirname "$out")"
echo "build_pinocchio_bench: g++ ${flags[*]} $defs" >&2
# shellcheck disable=SC2086
g++ "${flags[@]}" $defs \
    -isystem "$prefix/include" -isystem "$prefix/include/pinocchio/deprecated" \
    -isystem "$prefix/include/eigen3" -isystem "$prefix/include/urdfdom_headers" -isystem "$prefix/include/urdfdom" \
    "$here/pinocchio_bench.cpp" -o "$out" \
    -L"$prefix/lib" -Wl,-rpath,"$prefix/lib" \
    -lpinocchio_parsers -lpinocchio_default -lurdfdom_model -lboost_filesystem -lboost_serialization \
    || die "g++ failed (see above)"
echo "build_pinocchio_bench: built $out" >&2

if [ "${1:-}" = "--run" ]; then
    shift
    exec "$out" "$root/urdf/jk5.urdf" "$@"
fi
echo "$out"
