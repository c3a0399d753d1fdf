#!/usr/bin/env bash
# The frame rate a person steering the viewer gets: one rtpm-server and two rtpm-client processes
# on this machine (render threads as deploy/run-local.sh gives them), per scene in
# five modes, the server's own figures; prints one markdown row per scene.
#
#   tests/bench/modes_bench.sh [--scenes "RING GLASS HEADLIGHT"] [--size WxH] [--frames N]
#
# Modes (columns): light — a light edit every frame (--animate light), every frame a new epoch;
# walk — the camera orbits over the first frame's photons (--animate orbit --walkthrough);
# orbit — the camera orbits while photons accumulate (--animate orbit); still knn — the view
# stands, k-NN estimator (--estimator knn); still — the view stands, the defaults (progressive,
# passes growing or the sets taking turns to the 16.7 ms frame budget).
# fps: the server's rate over its last 8 frames (the CSV's fps of the last frame), so start-up
# and the first frames of a still view are left out; for the two still views over the last whole
# turn instead (the last frame's period rounded up to a multiple of 8 frames, from the CSV's
# 8-frame rates of disjoint windows): while the sets take turns longer than the set count, the
# passes come in one run and the frames without one in another (common/render/pass_budget.h
# passShoots), so an 8-frame window reads a burst of empty frames or a run of passes. Beside the
# still view: the estimated caustic
# error after the last frame, the seconds the run took (its summary line) and the last frame's
# pass work (batches per set, or 1/p when the sets take turns). The moving modes have no error
# figure: a moving light or camera has no converged reference to compare against, and the knn
# estimator reports none.
# Binaries from ${RTPM_BUILD_DIR:-<repo>/build}; render threads per client: $RTPM_BENCH_THREADS if set.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
source "$root/deploy/paths.sh"
build=${RTPM_BUILD_DIR:-$root/build}
scenes="RING GLASS HEADLIGHT" size=640x480 frames=30
if [[ ${RTPM_BENCH_SMOKE:-0} == 1 ]]; then scenes=RING size=64x48 frames=4; fi
while (($#)); do
    case $1 in
        --scenes) scenes=${2:?}; shift ;;
        --size) size=${2:?}; shift ;;
        --frames) frames=${2:?}; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "modes_bench.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
[[ $size =~ ^[0-9]+x[0-9]+$ ]] || { echo "modes_bench.sh: --size must be WxH, not '$size'" >&2; exit 2; }
[[ $frames =~ ^[0-9]+$ ]] && ((frames >= 2)) || { echo "modes_bench.sh: --frames must be >= 2" >&2; exit 2; }
w=${size%x*} h=${size#*x}
server_bin=$build/server/rtpm-server client_bin=$build/client/rtpm-client
for b in "$server_bin" "$client_bin"; do
    [[ -x $b ]] || { echo "modes_bench.sh: $b missing (build rtpm-server and rtpm-client)" >&2; exit 2; }
done
threads=${RTPM_BENCH_THREADS:-$(rtpmClientThreads 2)}

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-modes.XXXXXX")
pids=()
cleanup() {
    local p
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
    rm -rf "$work"
}
trap cleanup EXIT

# run SCENE NAME [server flags…]: one cluster run; sets fps, err and work from its CSV.
run() {
    local scene=$1 name=$2
    shift 2
    local csv=$work/$name.csv log=$work/$name.server.log token
    rm -f "$work/port" "$csv"
    token=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
    RTPM_TOKEN=$token "$server_bin" --port 0 --port-file "$work/port" --min-clients 2 --scene "$scene" \
        --width "$w" --height "$h" --frames "$frames" --csv "$csv" --out "$work/$name.exr" --quiet "$@" \
        >"$log" 2>&1 &
    local server=$!
    pids=("$server")
    local i c
    for ((i = 0; i < 600; i++)); do
        [[ -s $work/port ]] && break
        kill -0 "$server" 2>/dev/null || { cat "$log" >&2; return 1; }
        sleep 0.05
    done
    for c in 1 2; do
        RTPM_TOKEN=$token "$client_bin" --port-file "$work/port" --name "bench-$c" --threads "$threads" \
            >"$work/$name.client-$c.log" 2>&1 &
        pids+=("$!")
    done
    local status=0 p
    wait "$server" || status=$?
    for p in "${pids[@]:1}"; do wait "$p" 2>/dev/null || true; done
    pids=()
    if ((status != 0)); then
        echo "modes_bench.sh: rtpm-server exited with $status ($scene, $name)" >&2
        tail -n 20 "$log" >&2
        return 1
    fi
    # CSV: frame,fps,…,est_error (15),pass_batches (16),pass_period (17)
    fps=$(awk -F, 'NR > 1 { f = $2 } END { printf "%.2f", f }' "$csv")
    # Over the last whole turn: the CSV's fps is 8 / (t_k − t_(k−8)), so disjoint windows add up.
    turnFps=$(awk -F, 'NR > 1 { n++; r[n] = $2; p = $17 }
        END {
            w = p <= 8 ? 8 : 8 * int((p + 7) / 8)
            while (w > 8 && w > n - 8) w -= 8
            t = 0
            for (j = 0; j < w / 8; j++) t += (r[n - 8 * j] > 0 ? 8 / r[n - 8 * j] : 0)
            printf "%.2f", (t > 0 ? w / t : 0)
        }' "$csv")
    err=$(awk -F, 'NR > 1 { e = $15 } END { printf "%.4f", e }' "$csv")
    work_=$(awk -F, 'NR > 1 { b = $16; p = $17 } END { if (p > 1) printf "1/%d", p; else printf "%d", b }' "$csv")
    # The run's seconds from its summary line ("… frames shown (… incomplete) in S s = …").
    secs=$(sed -n 's/^summary: .* in \([0-9.]*\) s = .*/\1/p' "$log")
}

echo "### Frame rate by mode: ${w}x$h, 2 clients × $threads threads, $frames frames"
echo
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo
echo "| scene | light edits fps | walkthrough fps | orbit, accumulating fps | still knn fps (last turn) | still fps (last turn) | still: estimated error after its seconds, pass work |"
echo "|---|---|---|---|---|---|---|"
for scene in $scenes; do
    run "$scene" light --animate light
    light=$fps
    run "$scene" walk --animate orbit --walkthrough
    walk=$fps
    run "$scene" orbit --animate orbit
    orbit=$fps
    run "$scene" knn --estimator knn
    knn=$turnFps
    run "$scene" still
    still=$turnFps
    echo "| $scene | $light | $walk | $orbit | $knn | $still | $err after $secs s, $work_ |"
done
echo
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)"
