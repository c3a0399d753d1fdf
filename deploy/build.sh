#!/usr/bin/env bash
# Installs missing dependencies, then configures and builds rtpm (Release) into ${RTPM_BUILD_DIR:-build}.
# Extra arguments are passed to the CMake configure step (e.g. -DRTPM_SANITIZE=ON).
# RTPM_BUILD_TARGETS (space-separated) limits the build to those targets; default: everything.
# RTPM_BUILD_SCOPE says what the build folder is for:
#   all       (default) programs, tests and benchmarks: install-deps.sh dev; a folder configured
#             without tests or benchmarks is reconfigured with them
#   programs  rtpm-server, rtpm-client, rtpm-render, rtpm-compare: install-deps.sh build (no test
#             or benchmark packages); a new folder is configured without tests and benchmarks, an
#             existing one is left as it is configured
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
scope=${RTPM_BUILD_SCOPE:-all}
cache=$build/CMakeCache.txt
scope_args=()
case $scope in
    all)
        bash "$root/deploy/install-deps.sh" dev
        if [[ ! -f $cache ]] || grep -Eq '^RTPM_BUILD_(TESTS|BENCH):BOOL=OFF$' "$cache"; then
            scope_args=(-DRTPM_BUILD_TESTS=ON -DRTPM_BUILD_BENCH=ON)
        fi
        ;;
    programs)
        bash "$root/deploy/install-deps.sh" build
        [[ -f $cache ]] || scope_args=(-DRTPM_BUILD_TESTS=OFF -DRTPM_BUILD_BENCH=OFF)
        ;;
    *) echo "build.sh: RTPM_BUILD_SCOPE must be all or programs, got '$scope'" >&2; exit 2 ;;
esac
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f $cache ]]; then
    cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "${scope_args[@]}" "$@"
elif ((${#scope_args[@]} + $#)); then
    cmake "$build" "${scope_args[@]}" "$@"
fi
targets=()
for t in ${RTPM_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build" "${targets[@]}" -j "$(nproc)"
