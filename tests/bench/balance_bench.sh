#!/usr/bin/env bash
# Load balance by measured cost (server/balance.h): two clients, one held to half a core, fps of
# the balanced share against the round-robin one (--static-sets) and against what the two
# clients' capacities allow, in one run of this script; prints markdown.
#
#   tests/bench/balance_bench.sh [--size WxH] [--frames N] [--modes "light still"] [--scene S]
#
#   --size WxH     resolution (default 640x480)
#   --frames N     frames per run (default 24); fps is the server's rate over its last 8 frames
#   --modes "…"    light: --animate light, a light edit every frame, so every frame starts an
#                  epoch and the share may change at each; still: a still view after settings
#                  edits at frames 1–6 (P 20 001 and 20 000 by turns, the last one back to the
#                  default), whose epochs let the share move, with --frame-budget-ms 0 so that
#                  every still frame is the same work (one batch per pass, every set, no turns:
#                  a budget would fill each frame with whatever the clients manage, and its fps
#                  would say how the budget settled, not what the clients can do); within the
#                  still view's epoch the share stays. Default "light still".
#   --scene S      built-in scene (default RING)
#   --brake B      how the slow client is held: cgroup (default; half a core, see below) or
#                  slowdown (--slowdown-for-tests 2: twice its work time whatever the machine's
#                  load; on a machine whose load leaves each process less than half a core the
#                  quota never binds and both clients run alike)
#
# The slow client runs in a cgroup v1 CPU group with cpu.cfs_quota_us = 50000 of a 100000 µs
# period (half a core; needs root and /sys/fs/cgroup/cpu). Where that cannot be made, it runs
# with the hidden test flag --slowdown-for-tests 2 instead, and the table says so. Each client
# renders with one thread. Capacity: each client alone (the server and that client only) gives
# fps_fast and fps_slow; two clients sharing the sets perfectly would reach fps_fast + fps_slow
# ("ideal"). The deadline is fixed at 600 s so that no frame is shown with missing sets.
# The machine is shared: compare the ratios of one run, and read the load printed beside them.
# RTPM_BENCH_SMOKE=1: 64x48, 6 frames, the light mode only (tests/bench/smoke.sh).
# Binaries from ${RTPM_BUILD_DIR:-<repo>/build}.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
size=640x480 frames=24 modes="light still" scene=RING brakeKind=cgroup
if [[ ${RTPM_BENCH_SMOKE:-0} == 1 ]]; then size=64x48 frames=6 modes=light; fi
while (($#)); do
    case $1 in
        --size) size=$2; shift ;;
        --frames) frames=$2; shift ;;
        --modes) modes=$2; shift ;;
        --scene) scene=$2; shift ;;
        --brake) brakeKind=$2; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "balance_bench.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
[[ $size =~ ^[0-9]+x[0-9]+$ ]] || { echo "balance_bench.sh: --size must be WxH, not '$size'" >&2; exit 2; }
[[ $frames =~ ^[0-9]+$ ]] && ((frames >= 3)) || { echo "balance_bench.sh: --frames must be >= 3" >&2; exit 2; }
[[ $brakeKind == cgroup || $brakeKind == slowdown ]] || { echo "balance_bench.sh: --brake must be cgroup or slowdown" >&2; exit 2; }
for m in $modes; do
    [[ $m == light || $m == still ]] || { echo "balance_bench.sh: unknown mode '$m' (light still)" >&2; exit 2; }
done
w=${size%x*} h=${size#*x}
server_bin=$build/server/rtpm-server client_bin=$build/client/rtpm-client
for b in "$server_bin" "$client_bin"; do
    [[ -x $b ]] || { echo "balance_bench.sh: $b missing (build rtpm-server and rtpm-client)" >&2; exit 2; }
done

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-balance.XXXXXX")
group=/sys/fs/cgroup/cpu/rtpm-balance-$$
pids=()
cleanup() {
    local p
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
    [[ -d $group ]] && rmdir "$group" 2>/dev/null || true
    rm -rf "$work"
}
trap cleanup EXIT

# The slow client's brake: a half-core CPU group, or the test flag where none can be made.
slow=(--slowdown-for-tests 2)
brake="--slowdown-for-tests 2 (no cgroup v1 CPU group could be made)"
[[ $brakeKind == slowdown ]] && brake="--slowdown-for-tests 2 (--brake slowdown)"
if [[ $brakeKind == cgroup ]] && mkdir "$group" 2>/dev/null && echo 100000 >"$group/cpu.cfs_period_us" && echo 50000 >"$group/cpu.cfs_quota_us"; then
    slow=()
    brake="half a core (cgroup v1 cpu.cfs_quota_us 50000 / cpu.cfs_period_us 100000)"
fi

kClientGoneS=10
kRunLimitS=900
((${RTPM_BENCH_SMOKE:-0} == 1)) && kRunLimitS=120

# run NAME MODE CLIENTS [server flags…]: one cluster run; CLIENTS is fast, slow or both. Sets
# fps (the server's rate over its last 8 frames), incomplete frames and the last share line.
run() {
    local name=$1 mode=$2 who=$3
    shift 3
    local csv=$work/$name.csv log=$work/$name.server.log n=2 anim=()
    [[ $who != both ]] && n=1
    [[ $mode == light ]] && anim=(--animate light)
    if [[ $mode == still ]]; then
        local f
        : >"$work/still-edits.txt"
        for f in 1 2 3 4 5 6; do echo "frame $f settings P $((f % 2 ? 20001 : 20000))" >>"$work/still-edits.txt"; done
        anim=(--edit-script "$work/still-edits.txt" --frame-budget-ms 0)
    fi
    rm -f "$work/port" "$csv"
    local token
    token=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
    RTPM_TOKEN=$token "$server_bin" --port 0 --port-file "$work/port" \
        --min-clients "$n" --scene "$scene" --width "$w" --height "$h" --frames "$frames" --deadline-ms 600000 \
        --csv "$csv" --out "$work/$name.exr" --quiet "${anim[@]}" "$@" >"$log" 2>&1 &
    local server=$!
    pids=("$server")
    local i
    for ((i = 0; i < 600; i++)); do
        [[ -s $work/port ]] && break
        kill -0 "$server" 2>/dev/null || { cat "$log" >&2; return 1; }
        sleep 0.05
    done
    if [[ $who == fast || $who == both ]]; then
        RTPM_TOKEN=$token "$client_bin" --port-file "$work/port" --name fast --threads 1 >"$work/$name.fast.log" 2>&1 &
        pids+=("$!")
    fi
    if [[ $who == slow || $who == both ]]; then
        if ((${#slow[@]})); then
            RTPM_TOKEN=$token "$client_bin" --port-file "$work/port" --name slow --threads 1 "${slow[@]}" \
                >"$work/$name.slow.log" 2>&1 &
        else
            # The shell joins the group, then becomes the client: every thread it starts is held.
            RTPM_TOKEN=$token bash -c 'echo $$ >"$1/cgroup.procs" && shift && exec "$@"' _ "$group" \
                "$client_bin" --port-file "$work/port" --name slow --threads 1 >"$work/$name.slow.log" 2>&1 &
        fi
        pids+=("$!")
    fi
    # The server ends the run and its clients with it. A client gone while the server still waits
    # for it (it never connected, or died) would leave the server waiting for as long as the
    # deadline: after kClientGoneS more seconds, or past kRunLimitS in all, its logs are shown and
    # the script ends (cleanup stops the processes).
    local status=0 p start=$SECONDS gone=0
    while kill -0 "$server" 2>/dev/null; do
        if ((gone == 0)); then
            for p in "${pids[@]:1}"; do kill -0 "$p" 2>/dev/null || gone=$SECONDS; done
        fi
        if ((gone > 0 && SECONDS - gone > kClientGoneS || SECONDS - start > kRunLimitS)); then
            echo "balance_bench.sh: run $name stopped: $( ((gone > 0)) && echo "a client exited ${kClientGoneS} s before the server" || echo "over ${kRunLimitS} s")" >&2
            for f in "$work/$name".*.log; do [[ -f $f ]] && { echo "--- $(basename "$f")" >&2; tail -n 20 "$f" >&2; }; done
            return 1
        fi
        sleep 0.1
    done
    wait "$server" || status=$?
    for p in "${pids[@]:1}"; do wait "$p" 2>/dev/null || true; done
    pids=()
    if ((status != 0)); then
        echo "balance_bench.sh: rtpm-server exited with $status" >&2
        tail -n 20 "$log" >&2
        return 1
    fi
    # CSV: frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,sets,…
    fps=$(awk -F, 'NR > 1 { f = $2 } END { printf "%.2f", f }' "$csv")
    incomplete=$(awk -F, 'NR > 1 && $8 < $9 { n++ } END { print n + 0 }' "$csv")
    share=$(grep 'sets by measured cost' "$log" | tail -n 1 | sed 's/.*client: sets (cost) //' || true)
    moves=$(grep -c 'sets by measured cost' "$log" || true)
}

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (b > 0) printf "%.2f", a / b; else print "n/a" }'; }

echo "### Load balance by measured cost: $scene ${w}x$h, $frames frames, slow client at $brake"
echo
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| mode | fps fast alone | fps slow alone | ideal (sum) | fps static | static / ideal | fps balanced | balanced / ideal | balanced / static | share changes | last share (client: sets, cost per set) | incomplete frames |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for mode in $modes; do
    run "$mode-fast" "$mode" fast --static-sets
    fa=$fps
    run "$mode-slow" "$mode" slow --static-sets
    sa=$fps
    run "$mode-static" "$mode" both --static-sets
    st=$fps sti=$incomplete
    run "$mode-balanced" "$mode" both
    ba=$fps bai=$incomplete
    ideal=$(awk -v a="$fa" -v b="$sa" 'BEGIN { printf "%.2f", a + b }')
    echo "| $mode | $fa | $sa | $ideal | $st | $(ratio "$st" "$ideal") | $ba | $(ratio "$ba" "$ideal") |" \
        "$(ratio "$ba" "$st") | $moves | ${share:-none} | $sti / $bai |"
done
echo
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
