#!/usr/bin/env bash
# Speed-against-error sweep (tests/bench/SWEEP.md): builds the four executables it runs, then
# hands over to sweep.py. References go to <build>/sweep-cache, outside git; never run by ctest.
#   tests/bench/sweep.sh --make-references     converged references (once; ~5-10 min on 2 cores)
#   tests/bench/sweep.sh                       the sweep (~20 min) -> sweep_results.csv, SWEEP.md, PNGs
#   tests/bench/sweep.sh --report              rewrite SWEEP.md and the PNGs from the CSV
# Build directory: $RTPM_BUILD_DIR (default build/). Other arguments go to sweep.py.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
if [[ " $* " != *" --report "* || " $* " == *" --run "* || " $* " == *" --make-references "* ]]; then
    [[ -f $build/CMakeCache.txt ]] || cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
    cmake --build "$build" --target rtpm-render rtpm-compare rtpm-server rtpm-client -j 2 >&2
fi
args=("$@")
if [[ " $* " != *" --make-references "* && " $* " != *" --report "* && " $* " != *" --run "* ]]; then
    args+=(--run)
fi
exec /usr/bin/python3 "$root/tests/bench/sweep.py" --build "$build" "${args[@]}"
