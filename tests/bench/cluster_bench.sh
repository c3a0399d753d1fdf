#!/usr/bin/env bash
# End-to-end cluster benchmarks (paper Tables 6–7) and a long-run memory check; prints markdown.
#
#   tests/bench/cluster_bench.sh [--refs] [--scaling] [--resolution] [--memory] [options]
#
#   --refs           render the converged references the error columns need (rtpm-render, one
#                    frame of --ref-photons paths per set, k = --ref-k, another seed) into $REFS
#                    (default <build>/refs, outside git); only missing ones are made. Without
#                    --refs a missing reference gives "n/a".
#   --scaling        fps vs clients 1/2/4 at 640x480, interaction and walkthrough (Table 6)
#   --resolution     fps vs resolution 640x480 … 1280x960 with --res-clients clients (Table 7)
#   --memory         server and client VmRSS over a long run with an edit every --mem-every frames
#   --all            --scaling --resolution --memory (references are still only made with --refs)
#   --scenes "A B"   scenes (default "MIRROR RING GLASS HEADLIGHT"). MIRROR is the curved-mirror
#                    scene of tests/support/ring_mirror.h (smooth cylinder, point light, camera
#                    straight down), written as .glb by `ring_mirror_bench --write-scene` and
#                    rendered with L S D paths only (--photon-depth 2 --diffuse-bounces 0); its
#                    error is against the closed-form reference. The others are rtpm built-ins.
#   --estimator E    caustic estimator of the runs: progressive (default) or knn
#   --clients "1 2 4"            client counts for --scaling
#   --scaling-size WxH           resolution for --scaling (default 640x480)
#   --sizes "640x480 …"          resolutions for --resolution (and --refs)
#   --frames N       frames per interaction run (default 6)
#   --walk-frames N  frames per walkthrough run (default 6: 1 shooting frame + 5 walkthrough)
#   --walk-photons P paths per set shot in the walkthrough run's only shooting frame (default 200000)
#   --res-clients N  clients for --resolution (default 2)
#   --res-modes "…"  modes for --resolution (default "walkthrough interaction")
#   --mem-frames N --mem-size WxH --mem-every N --mem-sample N --mem-clients N --mem-photons P
#                    --mem-scene S (defaults 5000, 64x48, 100, 100, 2, 2000, RING)
#
# Binaries come from ${RTPM_BUILD_DIR:-<repo>/build-clusterbench} (built here if missing: only
# rtpm-server, rtpm-client, rtpm-render, rtpm-compare, ring_mirror_bench, -j2). Clusters start as deploy/run-local.sh
# starts them (server on port 0 with a port file, random token, render threads per client by
# deploy/paths.sh rtpmClientThreads), but the processes are started here so their PIDs can be sampled.
#
# Modes. interaction: P = 20 000 paths per set are shot every frame and accumulate (no cap is
# reached); the photon count and error are those of the last frame. walkthrough (--walkthrough):
# frame 0 shoots --walk-photons paths per set, later frames only trace pixels.
# fps: the server's rate over the frames shown after frame 0 (its sliding window of 8 frames
# holds them all when the run has at most 9 frames), so it excludes startup and, in walkthrough,
# the shooting frame. cpu s/frame: user+system CPU seconds of the server and all clients per frame
# over the same frames (total CPU of the reaped processes minus what they had used when frame 0
# was shown); on a loaded machine it says what a frame costs when the wall clock does not, and
# cores / (cpu s/frame) is the fps the run would reach on dedicated cores if it parallelised
# perfectly (an upper bound, labelled "fps bound"). Photons: stored photons summed over all interleaving sets at the last frame.
# Errors, of the last frame's caustic_filtered layer (the caustic as shown):
#   MIRROR: against the analytic reference (`ring_mirror_bench --compare --layer caustic_filtered`):
#     rel. MAE over the caustic region of the reference and the caustic energy ratio Σ out / Σ ref
#     over the floor inside the ring. Independent of the estimator (no photon map in it).
#   RING, GLASS, HEADLIGHT: rtpm-compare relative RMSE over the caustic region against a
#     self-rendered k-NN reference (--refs: rtpm-render, --estimator knn, one frame of
#     --ref-photons paths per set, k = --ref-k, another seed). It shares the k-NN estimator's
#     bias (blur of a gather radius), so it measures noise and the cluster's agreement with
#     rtpm-render, not accuracy.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
source "$root/deploy/paths.sh"
build=${RTPM_BUILD_DIR:-$root/build-clusterbench}
refs=${REFS:-$build/refs}
scenes="MIRROR RING GLASS HEADLIGHT"
estimator=progressive
frames=6
walkFrames=6
walkPhotons=200000
clientCounts="1 2 4"
scalingSize=640x480
sizes="640x480 800x600 1024x768 1280x960"
resClients=2
resModes="walkthrough interaction"
memFrames=5000 memSize=64x48 memEvery=100 memSample=100 memClients=2 memPhotons=2000 memScene=RING
doRefs=0 doScaling=0 doResolution=0 doMemory=0
failures=0
refPhotons=2000000 refK=200 refSeed=977

while (($#)); do
    case $1 in
        --refs) doRefs=1 ;;
        --scaling) doScaling=1 ;;
        --resolution) doResolution=1 ;;
        --memory) doMemory=1 ;;
        --all) doScaling=1 doResolution=1 doMemory=1 ;;
        --scenes) scenes=$2; shift ;;
        --estimator) estimator=$2; shift ;;
        --frames) frames=$2; shift ;;
        --walk-frames) walkFrames=$2; shift ;;
        --walk-photons) walkPhotons=$2; shift ;;
        --clients) clientCounts=$2; shift ;;
        --scaling-size) scalingSize=$2; shift ;;
        --sizes) sizes=$2; shift ;;
        --ref-photons) refPhotons=$2; shift ;;
        --ref-k) refK=$2; shift ;;
        --mem-scene) memScene=$2; shift ;;
        --res-clients) resClients=$2; shift ;;
        --res-modes) resModes=$2; shift ;;
        --mem-frames) memFrames=$2; shift ;;
        --mem-size) memSize=$2; shift ;;
        --mem-every) memEvery=$2; shift ;;
        --mem-sample) memSample=$2; shift ;;
        --mem-clients) memClients=$2; shift ;;
        --mem-photons) memPhotons=$2; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "cluster_bench.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
if [[ $estimator != progressive && $estimator != knn ]]; then
    echo "cluster_bench.sh: --estimator must be progressive or knn, not '$estimator'" >&2
    exit 2
fi
for scene in $scenes; do
    case $scene in MIRROR | RING | GLASS | EGG | HEADLIGHT | CORNELL) ;;
        *) echo "cluster_bench.sh: unknown scene '$scene' (MIRROR RING GLASS EGG HEADLIGHT CORNELL)" >&2; exit 2 ;;
    esac
done
if ((frames < 3 || frames > 9 || walkFrames < 3 || walkFrames > 9)); then
    echo "cluster_bench.sh: --frames and --walk-frames must be in [3, 9] (fps is the server's rate over the frames after frame 0, a window of 8)" >&2
    exit 2
fi

server_bin=$build/server/rtpm-server
client_bin=$build/client/rtpm-client
render_bin=$build/common/cmd/rtpm-render
compare_bin=$build/common/cmd/rtpm-compare
mirror_bin=$build/tests/bench/ring_mirror_bench
for b in "$server_bin" "$client_bin" "$render_bin" "$compare_bin" "$mirror_bin"; do
    if [[ ! -x $b ]]; then
        [[ -f $build/CMakeCache.txt ]] || cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >&2
        cmake --build "$build" --target rtpm-server rtpm-client rtpm-render rtpm-compare ring_mirror_bench -j2 >&2
        break
    fi
done

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-clusterbench.XXXXXX")
pids=()
cleanup() {
    local status=$?
    trap - EXIT INT TERM
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
export RTPM_TOKEN
cores=$(nproc)

refPath() { echo "$refs/${1}_${2}x${3}_knn.exr"; }

# The curved-mirror scene as a file the server loads (and sends to the clients).
mirrorGlb=$work/ring_mirror.glb
if [[ " $scenes " == *" MIRROR "* ]]; then
    "$mirror_bin" --write-scene "$mirrorGlb" >/dev/null
fi

# sceneArgs SCENE: the server's scene flags (MIRROR: the .glb with L S D photon paths only).
sceneArgs() {
    if [[ $1 == MIRROR ]]; then
        echo "--scene $mirrorGlb --photon-depth 2 --diffuse-bounces 0"
    else
        echo "--scene $1"
    fi
}

# start_cluster CLIENTS SCENE SERVER_ARGS... : starts the server and clients in the background,
# sets server_pid and client_pids. Readiness is the port file (bounded poll).
start_cluster() {
    local n=$1 scene=$2
    shift 2
    rm -f "$work/port"
    # shellcheck disable=SC2046  # sceneArgs: words without spaces ($work is mktemp's)
    "$server_bin" --port 0 --port-file "$work/port" --min-clients "$n" $(sceneArgs "$scene") --quiet \
        --deadline-ms 600000 --estimator "$estimator" "$@" \
        >"$work/server.log" 2>&1 &
    server_pid=$!
    pids+=("$server_pid")
    local i
    for ((i = 0; i < 600; i++)); do
        [[ -s $work/port ]] && break
        kill -0 "$server_pid" 2>/dev/null || { cat "$work/server.log" >&2; return 1; }
        sleep 0.05
    done
    [[ -s $work/port ]] || { echo "server did not listen within 30 s" >&2; return 1; }
    local threads
    threads=$(rtpmClientThreads "$n")
    client_pids=()
    for ((i = 1; i <= n; i++)); do
        "$client_bin" --port-file "$work/port" --name "bench-$i" --threads "$threads" >"$work/client-$i.log" 2>&1 &
        client_pids+=("$!")
        pids+=("$!")
    done
}

# wait_cluster: waits for the server, then the clients (the server's Bye ends them).
wait_cluster() {
    local status=0 p
    wait "$server_pid" || status=$?
    for p in "${client_pids[@]}"; do wait "$p" 2>/dev/null || true; done
    pids=()  # all reaped: never signal a PID that may since have been reused
    if ((status != 0)); then
        echo "rtpm-server exited with $status:" >&2
        tail -n 20 "$work/server.log" >&2
    fi
    return $status
}

# error OUT.exr SCENE W H: "analytic rel. MAE|analytic energy ratio|self-rendered rel. RMSE" of
# the caustic_filtered layer, "—" where a column does not apply, n/a for a missing reference.
error() {
    if [[ $2 == MIRROR ]]; then
        "$mirror_bin" --compare "$1" --layer caustic_filtered |
            awk '$1 == "rel_mae" && $3 == "energy" { printf "%.3f|%.3f|—", $2, $4; ok = 1 }
                 END { if (!ok) printf "n/a|n/a|—" }'
        return
    fi
    local ref
    ref=$(refPath "$2" "$3" "$4")
    [[ -f $ref ]] || { echo "—|—|n/a"; return; }
    "$compare_bin" --csv --layer caustic_filtered "$1" "$ref" | awk -F, 'NR == 2 { printf "—|—|%.3f", $6 }'
}


# childCpu FILE: user+system CPU seconds of all reaped children of this shell so far, from the
# shell builtin `times` (it must run in this shell, not in a command substitution).
childCpu() {
    times >"$1"
    awk 'NR == 2 { t = 0
        for (i = 1; i <= 2; i++) { split($i, a, /[ms]/); t += a[1] * 60 + a[2] }
        printf "%.3f\n", t }' "$1"
}

# procCpu PID...: user+system CPU seconds the running processes used so far (/proc/<pid>/stat).
procCpu() {
    local p t=0
    for p in "$@"; do t=$(awk -v t="$t" -v hz="$clk" '{ printf "%.3f", t + ($14 + $15) / hz }' "/proc/$p/stat" 2>/dev/null || echo "$t"); done
    echo "$t"
}
clk=$(getconf CLK_TCK)

# run_case CLIENTS SCENE W H MODE: one cluster run (in this shell, so `times` sees it); sets
# result="fps|cpu_s_per_frame|photons_total|analytic_mae|analytic_energy|self_rmse|frames|incomplete|last_mode|split"
# (split: the slowest client's photon / eye / encode ms and the master's ms per frame).
run_case() {
    local n=$1 scene=$2 w=$3 h=$4 mode=$5
    local csv=$work/run.csv out=$work/run.exr cpu0 cpu1 args
    rm -f "$csv" "$out"
    if [[ $mode == walkthrough ]]; then
        args=(--walkthrough --frames "$walkFrames" --photons "$walkPhotons")
    else
        args=(--frames "$frames")
    fi
    childCpu "$work/times" >"$work/cpu0"
    cpu0=$(cat "$work/cpu0")
    start_cluster "$n" "$scene" --width "$w" --height "$h" --csv "$csv" --out "$out" "${args[@]}" || return 1
    # CPU used up to the moment frame 0 is shown (startup, scene load, BVH, frame 0), so the
    # per-frame CPU of the later frames can be told apart.
    local at0=""
    while kill -0 "$server_pid" 2>/dev/null; do
        if [[ -z $at0 && -f $csv ]] && (($(wc -l <"$csv") >= 2)); then
            at0=$(procCpu "$server_pid" "${client_pids[@]}")
        fi
        sleep 0.05
    done
    wait_cluster || return 1
    childCpu "$work/times" >"$work/cpu1"
    cpu1=$(cat "$work/cpu1")
    local fps cpuf ph nf inc lastMode split err
    # CSV: frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,sets,deadline,
    # master_ms,slowest_photon_ms,slowest_eye_ms,slowest_encode_ms. The split is the mean over the
    # frames after the first (the ones the CPU column covers).
    IFS='|' read -r fps cpuf ph nf inc lastMode split < <(awk -F, -v c0="$cpu0" -v c1="$cpu1" -v a0="$at0" '
        NR == 1 { next }
        { n++; fps = $2; ph = $3 * $9; mode = $4; inc += ($8 < $9) }
        NR > 2 { m++; sp += $12; se += $13; sc += $14; sm += $11 }
        END { cf = a0 == "" || n < 2 ? "n/a" : sprintf("%.2f", (c1 - c0 - a0) / (n - 1))
              sl = m ? sprintf("%.0f / %.0f / %.1f / %.0f", sp / m, se / m, sc / m, sm / m) : "n/a"
              printf "%.3f|%s|%.0f|%d|%d|%s|%s\n", fps, cf, ph, n, inc, mode, sl }' "$csv")
    err=$(error "$out" "$scene" "$w" "$h")
    result="$fps|$cpuf|$ph|$err|$nf|$inc|$lastMode|$split"
}

make_refs() {
    mkdir -p "$refs"
    local scene size w h ref
    for scene in $scenes; do
        [[ $scene == MIRROR ]] && continue  # analytic reference
        for size in $sizes; do
            w=${size%x*} h=${size#*x}
            ref=$(refPath "$scene" "$w" "$h")
            [[ -f $ref ]] && continue
            echo "cluster_bench.sh: reference $ref" >&2
            "$render_bin" --scene "$scene" --width "$w" --height "$h" --frames 1 --photons "$refPhotons" \
                --k "$refK" --seed "$refSeed" --estimator knn --out "$ref" >"$work/ref.log" 2>&1 ||
                { cat "$work/ref.log" >&2; return 1; }
            tail -n 2 "$work/ref.log" | head -n 1 >&2
        done
    done
}

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (a == "n/a" || b == "n/a" || b == 0) print "n/a"; else printf "%.2f×", a / b }'; }
bound() { awk -v c="$1" -v n="$cores" 'BEGIN { if (c == "n/a" || c == 0) print "n/a"; else printf "%.2f", n / c }'; }

header() {
    echo "Machine: nproc = $cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'); load at start:$(uptime | sed 's/.*load average://')"
    echo
}

scaling() {
    local sw=${scalingSize%x*} sh=${scalingSize#*x}
    echo "### fps vs clients, $scalingSize, estimator $estimator (paper Table 6)"
    echo
    echo "Clients on loopback with min($cores, max(1, 2·$cores / N)) render threads each, plus the master, on $cores cores:"
    echo "N = 4 oversubscribes the machine. Interaction: $frames frames of P = 20 000 paths/set;"
    echo "walkthrough: --walkthrough, frame 0 shoots $walkPhotons paths/set, $((walkFrames - 1)) walkthrough frames."
    echo
    echo "| scene | estimator | mode | clients | fps | fps / fps(1 client) | cpu s/frame | cpu / cpu(1 client) | fps bound | photons (all sets) | caustic rel. MAE vs analytic | caustic energy vs analytic | caustic rel. RMSE vs self-rendered k-NN ref. | frames (incomplete) | ms/frame: photons / eye / encode (slowest client) / master |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    local scene mode n r base cbase
    for scene in $scenes; do
        for mode in interaction walkthrough; do
            base="" cbase=""
            for n in $clientCounts; do
                run_case "$n" "$scene" "$sw" "$sh" "$mode" && r=$result || { echo "| $scene | $estimator | $mode | $n | failed | | | | | | | | | | |"; failures=$((failures + 1)); continue; }
                IFS='|' read -r fps cpuf ph mae energy rmse nf inc lastMode split <<<"$r"
                [[ -z $base ]] && base=$fps cbase=$cpuf
                echo "| $scene | $estimator | $mode | $n | $fps | $(ratio "$fps" "$base") | $cpuf | $(ratio "$cpuf" "$cbase") | $(bound "$cpuf") | $ph | $mae | $energy | $rmse | $nf ($inc) | $split |"
                echo "  [$(date +%T) load$(uptime | sed 's/.*load average://')] $scene $mode $n: $r" >&2
            done
        done
    done
    echo
}

resolution() {
    echo "### fps vs resolution, $resClients clients, estimator $estimator (paper Table 7)"
    echo
    echo "| scene | estimator | mode | resolution | fps | px/s ÷ px/s at first size | cpu s/frame | cpu µs/px | fps bound | photons (all sets) | caustic rel. MAE vs analytic | caustic energy vs analytic | caustic rel. RMSE vs self-rendered k-NN ref. | frames (incomplete) | ms/frame: photons / eye / encode (slowest client) / master |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    local scene mode size w h r base
    for scene in $scenes; do
        for mode in $resModes; do
            base=""
            for size in $sizes; do
                w=${size%x*} h=${size#*x}
                run_case "$resClients" "$scene" "$w" "$h" "$mode" && r=$result || { echo "| $scene | $estimator | $mode | $size | failed | | | | | | | | | | |"; failures=$((failures + 1)); continue; }
                IFS='|' read -r fps cpuf ph mae energy rmse nf inc lastMode split <<<"$r"
                [[ -z $base ]] && base=$(awk -v f="$fps" -v w="$w" -v h="$h" 'BEGIN { print f * w * h }')
                echo "| $scene | $estimator | $mode | $size | $fps | $(awk -v f="$fps" -v w="$w" -v h="$h" -v b="$base" 'BEGIN { printf "%.2f", f * w * h / b }') | $cpuf | $(awk -v c="$cpuf" -v p="$((w * h))" 'BEGIN { if (c == "n/a") print "n/a"; else printf "%.2f", c / p * 1e6 }') | $(bound "$cpuf") | $ph | $mae | $energy | $rmse | $nf ($inc) | $split |"
                echo "  [$(date +%T) load$(uptime | sed 's/.*load average://')] $scene $mode $size: $r" >&2
            done
        done
    done
    echo
}

rssKb() { awk '/^VmRSS:/ { print $2 }' "/proc/$1/status" 2>/dev/null || echo 0; }

memory() {
    local w=${memSize%x*} h=${memSize#*x} script=$work/edits.txt csv=$work/mem.csv samples=$work/mem.txt
    # An edit every memEvery frames (a new epoch: every photon map is reset), alternating the ring
    # metal's colour between two values, so the scene does not drift.
    : >"$script"
    local f c
    for ((f = memEvery; f < memFrames; f += memEvery)); do
        if (((f / memEvery) % 2)); then c="0.94 0.92 0.87"; else c="0.95 0.93 0.88"; fi
        echo "frame $f material 1 color $c" >>"$script"
    done
    rm -f "$csv"
    local t0=$SECONDS
    start_cluster "$memClients" "$memScene" --width "$w" --height "$h" --frames "$memFrames" \
        --photons "$memPhotons" --csv "$csv" --out "" --edit-script "$script" || return 1
    : >"$samples"
    local next=0 shown p line
    while kill -0 "$server_pid" 2>/dev/null; do
        shown=0
        [[ -f $csv ]] && shown=$(($(wc -l <"$csv") - 1))
        if ((shown >= next)); then
            line="$shown $(rssKb "$server_pid")"
            for p in "${client_pids[@]}"; do line+=" $(rssKb "$p")"; done
            # A process that already exited reads 0: keep only complete samples.
            [[ $line == *" 0"* ]] || echo "$line" >>"$samples"
            next=$((next + memSample))
        fi
        sleep 0.1
    done
    wait_cluster || return 1
    local secs=$((SECONDS - t0))
    if [[ ! -s $samples ]]; then
        echo "cluster_bench.sh: no VmRSS sample: the run ended before the first one (raise --mem-frames)" >&2
        return 1
    fi
    echo "### Memory over a long run"
    echo
    echo "$memScene ${w}x${h}, $memClients clients, P = $memPhotons paths/set/frame, $memFrames frames in $secs s,"
    echo "an edit (ring metal colour) every $memEvery frames; VmRSS sampled every $memSample frames (MB)."
    echo
    local hdr="| frame | server"
    for ((c = 1; c <= memClients; c++)); do hdr+=" | client $c"; done
    echo "$hdr |"
    echo "|---$(for ((c = 0; c <= memClients; c++)); do printf '|---'; done)|"
    local rows
    rows=$(wc -l <"$samples")
    awk -v rows="$rows" 'NR == 1 || NR == rows || (NR - 1) % int((rows + 9) / 10) == 0 {
        printf "| %d", $1; for (i = 2; i <= NF; i++) printf " | %.1f", $i / 1024; print " |" }' "$samples"
    echo
    echo "| process | mean first quarter (MB) | mean last quarter (MB) | last / first | max (MB) |"
    echo "|---|---|---|---|---|"
    # A quarter is at least one sample (a short run may have fewer than four).
    awk -v rows="$rows" '
        BEGIN { q = rows < 4 ? 1 : rows / 4 }
        { for (i = 2; i <= NF; i++) { v = $i / 1024; if (v > mx[i]) mx[i] = v
              if (NR <= q) { a[i] += v; na[i]++ }
              if (NR > rows - q) { b[i] += v; nb[i]++ } }
          nf = NF }
        END { for (i = 2; i <= nf; i++) {
                name = i == 2 ? "server" : "client " (i - 2)
                printf "| %s | %.1f | %.1f | %.3f | %.1f |\n", name, a[i] / na[i], b[i] / nb[i], (b[i] / nb[i]) / (a[i] / na[i]), mx[i] } }' "$samples"
    echo
}

((doRefs)) && make_refs
if ((doScaling || doResolution || doMemory)); then
    header
    ((doScaling)) && scaling
    ((doResolution)) && resolution
    ((doMemory)) && memory
    echo "Load at end:$(uptime | sed 's/.*load average://')"
fi
# A failed run is a row of the table, and the exit status says so.
if ((failures)); then
    echo "cluster_bench.sh: $failures run(s) failed" >&2
    exit 1
fi
