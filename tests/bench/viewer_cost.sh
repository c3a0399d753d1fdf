#!/usr/bin/env bash
# The browser viewer's cost and lag at a chosen frame rate.
#
# The render clients of this 2-core machine reach ≈ 2–3 fps at 640×480, so the master is fed by
# two stand-ins (viewer_feed) that join like rtpm-client and answer every frame with the pixels of
# a RING frame rendered once beforehand, paced to FPS frames a second (0 = as fast as the master
# asks). The master does all its real per-frame work: decode, scatter, box filter, compose and the
# viewer. Two runs of N frames at W×H: without a page, and with a headless-Chromium page watching
# (the feeders start once the page is open, so every frame is composed while it watches).
#
# Reported: the server's CPU (user + sys, /usr/bin/time), the viewer's CPU as the server accounts
# it (tone map on the output thread + the viewer thread: JPEG, WebSocket and HTTP + building the
# status JSON on the frame loop), the viewer's share of the server's CPU, the extra server CPU
# of the run with a page over the run without, frames drawn, and the lag: newest composed frame −
# drawn frame when the page acknowledged it, and the composed → drawn time.
#
#   tests/bench/viewer_cost.sh [frames=300] [width=640] [height=480] [fps=30] [extra rtpm-server flags…]
#   VIEWER_COST_PAGES=2 …   (pages watching at once, all with the same display setting; default 1)
#   VIEWER_COST_CACHE=DIR … (where the replayed frame is rendered once and kept; default the build dir)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
frames=${1:-300}; width=${2:-640}; height=${3:-480}; fps=${4:-30}; shift $(($# < 4 ? $# : 4)) || true
work=$(mktemp -d)
pids=()
cleanup() {
    # /usr/bin/time's child (the server) first: killing time alone would orphan it.
    for p in "${pids[@]}"; do pkill -P "$p" 2>/dev/null || true; kill "$p" 2>/dev/null || true; done
    rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT TERM  # runs the EXIT trap
export RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d " \n")

exr=${VIEWER_COST_CACHE:-$build}/viewer_cost_ring_${width}x${height}.exr
if [[ ! -s $exr ]]; then
    echo "rendering the frame the feeders replay: $exr"
    "$build/common/cmd/rtpm-render" --scene RING --width "$width" --height "$height" --frames 2 --out "$exr" >/dev/null
fi

run() {  # $1 = with|without
    local tag=$1
    shift
    rm -f "$work/port" "$work/server.out" "$work/watch.out"
    /usr/bin/time -f "%U %S %e" -o "$work/time.$tag" \
        "$build/server/rtpm-server" --port 0 --port-file "$work/port" --http 127.0.0.1:0 --frames "$frames" \
        --width "$width" --height "$height" --min-clients 2 --quiet --out "$work/out.exr" "$@" \
        >"$work/server.out" 2>"$work/server.err" &
    local server=$!
    pids+=("$server")
    for ((i = 0; i < 600; i++)); do [[ -s $work/port ]] && grep -q '^viewer:' "$work/server.out" && break; sleep 0.05; done
    local url
    url=$(sed -n 's/^viewer: \(http:[^ ]*\)$/\1/p' "$work/server.out")
    [[ -n $url ]] || { echo "the server printed no viewer URL" >&2; cat "$work/server.err" >&2; exit 1; }
    if [[ $tag == with ]]; then
        (cd "$root/tests/browser" && exec node watch.mjs "${url}#token=$RTPM_TOKEN" "${VIEWER_COST_PAGES:-1}") >"$work/watch.out" 2>&1 &
        pids+=("$!")
        for ((i = 0; i < 1200; i++)); do grep -qs "^watch: open" "$work/watch.out" && break; sleep 0.05; done
        grep -q '^watch: open' "$work/watch.out" || { echo "the page did not open in 60 s" >&2; cat "$work/watch.out" >&2; exit 1; }
    fi
    for c in 1 2; do
        "$build/tests/bench/viewer_feed" --port-file "$work/port" --exr "$exr" --fps "$fps" --name "feed-$c" \
            >"$work/feed$c.log" 2>&1 &
        pids+=("$!")
    done
    wait "$server" || { echo "rtpm-server failed:" >&2; cat "$work/server.err" >&2; exit 1; }
    wait || true
    read -r user sys wall <"$work/time.$tag"
    local summary viewer
    summary=$(grep -E '^summary:' "$work/server.out" || true)
    viewer=$(grep -E '^viewer: [0-9]' "$work/server.out" || true)
    local vcpu
    vcpu=$(sed -n 's/.*viewer CPU \([0-9.]*\) s.*/\1/p' <<<"$viewer")
    eval "cpu_$tag=$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.3f", u + s }')"
    eval "wall_$tag=$wall"
    eval "frames_s_$tag=$(sed -n 's/.* in \([0-9.]*\) s = .*/\1/p' <<<"$summary")"
    eval "vcpu_$tag=${vcpu:-0}"
    echo "== $tag viewer pages (${VIEWER_COST_PAGES:-1} with): $frames frames at ${width}x${height}, feeders at ${fps} fps (0 = unpaced)"
    echo "server CPU: user $user s, sys $sys s, wall $wall s ($(awk -v f="$frames" -v w="$wall" 'BEGIN { printf "%.1f", f / w }') fps)"
    [[ -n $summary ]] && echo "$summary"
    [[ -n $viewer ]] && echo "$viewer"
    [[ $tag == with ]] && grep '^watch:' "$work/watch.out" | grep -v '^watch: open' || true
}
echo "load before: $(uptime)"
run without "$@"
echo "load between: $(uptime)"
run with "$@"
echo "load after: $(uptime)"
awk -v v="$vcpu_with" -v c="$cpu_with" -v c0="$cpu_without" -v w="$frames_s_with" -v n="$frames" 'BEGIN {
    printf "viewer CPU %.3f s = %.1f %% of the server CPU with the page (%.3f s); %.2f ms per frame; %.1f %% of one core while frames flowed (%.2f s)\n",
        v, 100 * v / c, c, 1000 * v / n, 100 * v / w, w
    printf "server CPU with the page − without: %+.3f s (%+.1f %% of %.3f s; noisy on a shared machine)\n", c - c0, 100 * (c - c0) / c0, c0
}'
