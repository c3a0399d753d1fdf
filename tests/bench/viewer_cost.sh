#!/usr/bin/env bash
# The browser viewer's cost: runs a local cluster (server + 2 one-thread clients) for N frames at
# W×H, once with a headless-Chromium page watching and once without, under /usr/bin/time, and
# prints the server's CPU time, the viewer's own CPU (tone mapping + JPEG + WebSocket thread, as
# the server reports it) and the page's lag behind the newest frame.
#
#   tests/bench/viewer_cost.sh [frames=40] [width=640] [height=480] [extra rtpm-server flags…]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
frames=${1:-40}; width=${2:-640}; height=${3:-480}; shift $(($# < 3 ? $# : 3)) || true
work=$(mktemp -d)
pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$work"' EXIT
export RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d " \n")

run() {  # $1 = with|without
    local tag=$1
    shift
    rm -f "$work/port" "$work/server.out"
    /usr/bin/time -f "server CPU: user %U s, sys %S s, wall %e s" -o "$work/time.$tag" \
        "$build/server/rtpm-server" --port 0 --port-file "$work/port" --http 127.0.0.1:0 --frames "$frames" \
        --width "$width" --height "$height" --min-clients 2 --quiet --out "$work/out.exr" "$@" >"$work/server.out" 2>"$work/server.err" &
    local server=$!
    pids+=("$server")
    for ((i = 0; i < 600; i++)); do [[ -s $work/port ]] && grep -q '^viewer:' "$work/server.out" && break; sleep 0.05; done
    local url
    url=$(sed -n 's/^viewer: \(http:[^ ]*\)$/\1/p' "$work/server.out")
    for c in 1 2; do
        "$build/client/rtpm-client" --port-file "$work/port" --name "cost-$c" --threads 1 >"$work/client$c.log" 2>&1 &
        pids+=("$!")
    done
    if [[ $tag == with ]]; then
        (cd "$root/tests/browser" && node watch.mjs "${url}#token=$RTPM_TOKEN") &
        pids+=("$!")
    fi
    wait "$server" || true
    wait || true
    echo "== $tag a viewer page: $frames frames at ${width}x${height}"
    cat "$work/time.$tag"
    grep -E '^(viewer: [0-9]|summary:)' "$work/server.out"
}
echo "load before: $(uptime)"
run without "$@"
run with "$@"
echo "load after: $(uptime)"
