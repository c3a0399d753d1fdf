#!/usr/bin/env bash
# Installs what the `browser` ctest label needs: Debian's chromium, Node.js and npm when absent,
# and puppeteer-core at the version tests/browser/package-lock.json pins (npm ci, from the npm
# registry) into tests/browser/node_modules. Idempotent; deploy/test.sh (and so CI) runs it.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
need=()
command -v chromium >/dev/null || need+=(chromium)
command -v node >/dev/null || need+=(nodejs)
command -v npm >/dev/null || need+=(npm)
if ((${#need[@]})); then
    SUDO=""
    [[ $(id -u) -ne 0 ]] && SUDO="sudo"
    export DEBIAN_FRONTEND=noninteractive
    echo "install-browser-test: installing ${need[*]}"
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}"
fi
cd "$root/tests/browser"
if [[ -f node_modules/puppeteer-core/package.json ]] && npm ls --silent >/dev/null 2>&1; then
    echo "install-browser-test: puppeteer-core present"
    exit 0
fi
npm ci --no-audit --no-fund
