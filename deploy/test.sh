#!/usr/bin/env bash
# Builds rtpm (installing dependencies if needed, and Chromium + puppeteer-core for the `browser`
# label) and runs the whole test suite with ctest.
# Pass ctest arguments to narrow it, e.g. `deploy/test.sh -L unit`.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
bash "$root/deploy/install-browser-test.sh"
bash "$root/deploy/build.sh"
cd "$build"
ctest --output-on-failure -j "$(nproc)" --timeout 600 "$@"
