#!/usr/bin/env bash
# Installs missing dependencies, then configures and builds rtpm (Release) into ${RTPM_BUILD_DIR:-build}.
# Extra arguments are passed to the CMake configure step (e.g. -DRTPM_SANITIZE=ON).
# RTPM_BUILD_TARGETS (space-separated) limits the build to those targets; default: everything.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
bash "$root/deploy/install-deps.sh"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [[ ! -f $build/CMakeCache.txt ]]; then
    cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "$@"
elif (($#)); then
    cmake "$build" "$@"
fi
targets=()
for t in ${RTPM_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build" "${targets[@]}" -j "$(nproc)"
