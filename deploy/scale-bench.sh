#!/usr/bin/env bash
# Scaling by client count past the cores of one machine (root): every client is an emulated host —
# its own network namespace on a 100 Mbit/s tbf-shaped link and its own CPU quota (cgroup v1
# cpu.cfs_quota_us, one render thread) — and the master another, on a 1 Gbit/s uplink with its
# own quota, as in the paper's set-up (§6, Table 6). For each client count and for interaction and
# walkthrough it records fps, CPU seconds per frame (master and clients, from cgroup cpuacct),
# bytes per frame, stored photons, the caustic error against a converged reference and the load
# of the machine; then deploy/scale-bench.py writes a markdown table, a PNG plot and a MODEL
# extrapolated from the measured per-set cost and bytes per frame to 64 clients and 1/10/25 Gbit/s
# master links, saying where the master's network or CPU saturates.
#
#   deploy/scale-bench.sh [--clients "1 2 4 8 16"] [--scene RING] [--size 320x240] [-M 4]
#                         [--client-cores 0.1] [--master-cores 0.3] [--frames 7]
#                         [--walk-frames 7] [--walk-photons 50000] [--out DIR] [--refs DIR]
#                         [--ref-photons 2000000]
#
# M = 4 gives 16 interleaving sets, so up to 16 clients all own sets (more would wait as spares).
# A last run repeats the largest cluster's walkthrough at twice the width and height, so the model
# can tell fixed from per-pixel costs. Outputs in DIR (default <build>/scale-bench): scale.csv
# (one row per run), scale.md, scale.png.
# Programs from ${RTPM_BUILD_DIR:-<repo>/build} (built if missing). The converged reference the
# error needs (rtpm-render, one frame of --ref-photons paths per set, k = 200, another seed; as
# tests/bench/cluster_bench.sh --refs makes it) is cached in --refs DIR (default <build>/refs).
# On a machine shared with other work the wall-clock figures (fps) are lower than the quotas
# allow; CPU seconds per frame are not: both are reported, with the load average of each run.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
source "$root/deploy/paths.sh"
source "$root/deploy/netns.sh"
clientCounts="1 2 4 8 16"
scene=RING
size=320x240
m=4
clientCores=0.1
masterCores=0.3
frames=7
walkFrames=7
walkPhotons=50000
out=""
refs=""
refPhotons=2000000
while (($#)); do
    case $1 in
        --clients) clientCounts=$2; shift ;;
        --scene) scene=$2; shift ;;
        --size) size=$2; shift ;;
        -M|--interleave) m=$2; shift ;;
        --client-cores) clientCores=$2; shift ;;
        --master-cores) masterCores=$2; shift ;;
        --frames) frames=$2; shift ;;
        --walk-frames) walkFrames=$2; shift ;;
        --walk-photons) walkPhotons=$2; shift ;;
        --out) out=$2; shift ;;
        --refs) refs=$2; shift ;;
        --ref-photons) refPhotons=$2; shift ;;
        -h|--help) sed -n '2,25p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "scale-bench: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
    shift
done
if ((frames < 3 || frames > 9 || walkFrames < 3 || walkFrames > 9)); then
    echo "scale-bench: --frames and --walk-frames must be in [3, 9] (the server's fps window is 8 frames)" >&2
    exit 2
fi
if ! reason=$(netnsCheck); then
    echo "scale-bench: cannot emulate hosts here: $reason" >&2
    exit 1
fi
out=${out:-$build/scale-bench}
refs=${refs:-$build/refs}
mkdir -p "$out"
w=${size%x*} h=${size#*x}

for name in rtpm-server rtpm-client rtpm-render rtpm-compare; do
    if ! rtpmProgram "$build" "$name" >/dev/null 2>&1; then
        RTPM_BUILD_DIR=$build RTPM_BUILD_TARGETS="rtpm-server rtpm-client rtpm-render rtpm-compare" \
            bash "$root/deploy/build.sh" >&2
        break
    fi
done
server_bin=$(rtpmProgram "$build" rtpm-server)
client_bin=$(rtpmProgram "$build" rtpm-client)
render_bin=$(rtpmProgram "$build" rtpm-render)
compare_bin=$(rtpmProgram "$build" rtpm-compare)

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-scale.XXXXXX")
pids=()
cleanup() {
    local status=$?
    trap - EXIT INT TERM
    local p
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
    netnsTeardown
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
export RTPM_TOKEN
RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')

# The converged reference (shared with cluster_bench.sh --refs: same settings, same file name).
# A reference of other than the default photon count is named after it, so the cache never mixes them.
ref=$refs/${scene}_${w}x${h}$( ((refPhotons == 2000000)) || echo "_p$refPhotons").exr
if [[ ! -f $ref ]]; then
    mkdir -p "$refs"
    echo "scale-bench: converged reference $ref (once)" >&2
    "$render_bin" --scene "$scene" --width "$w" --height "$h" --frames 1 --photons "$refPhotons" --k 200 \
        --seed 977 --out "$ref" >"$work/ref.log" 2>&1 || { cat "$work/ref.log" >&2; exit 1; }
fi

# run N MODE [SCALE]: one cluster of N emulated clients at SCALE × the size (default 1); appends
# a row to scale.csv.
run() {
    local n=$1 mode=$2 scale=${3:-1} args nf prefix i
    local w=$((w * scale)) h=$((h * scale))
    if [[ $mode == walkthrough ]]; then
        args=(--walkthrough --frames "$walkFrames" --photons "$walkPhotons")
        nf=$walkFrames
    else
        args=(--frames "$frames")
        nf=$frames
    fi
    prefix=rtpmsb$$n$n${mode:0:1}$scale
    netnsInit "$prefix"
    netnsHost master 10.213.0.1 1gbit
    cpuGroup master "$masterCores"
    for ((i = 1; i <= n; i++)); do
        netnsHost "c$i" "10.213.1.$i" 100mbit
        cpuGroup "c$i" "$clientCores"
    done
    rm -f "$work/port" "$work/run.csv" "$work/run.exr"
    local load
    load=$(awk '{ print $1 }' /proc/loadavg)
    cpuGroupRun master ip netns exec "$(netnsName master)" "$server_bin" --listen 10.213.0.1 --port 0 --port-file "$work/port" \
        --min-clients "$n" --deadline-ms 600000 --quiet --scene "$scene" --width "$w" --height "$h" \
        --interleave "$m" --csv "$work/run.csv" --out "$work/run.exr" "${args[@]}" >"$work/server.log" 2>&1 &
    local server_pid=$!
    pids=("$server_pid")
    for ((i = 0; i < 600; i++)); do
        [[ -s $work/port ]] && break
        kill -0 "$server_pid" 2>/dev/null || { cat "$work/server.log" >&2; return 1; }
        sleep 0.05
    done
    local port
    port=$(cat "$work/port")
    for ((i = 1; i <= n; i++)); do
        cpuGroupRun "c$i" ip netns exec "$(netnsName "c$i")" "$client_bin" --server "10.213.0.1:$port" --name "host-$i" \
            --threads 1 --connect-timeout 30 >"$work/client-$i.log" 2>&1 &
        pids+=("$!")
    done
    # CPU seconds are read when frame 0 is shown and when the last but one frame is shown:
    # start-up, scene, BVH and frame 0 are left out (as the fps window leaves frame 0 out), and so
    # is the last frame, whose row the master writes after the final image (EXR + PNG). Polled
    # every 20 ms; bounded: 1200 s per run.
    local at0m="" at0c="" atEm="" atEc="" shown t
    local clientGroups=()
    for ((i = 1; i <= n; i++)); do clientGroups+=("c$i"); done
    local alive=1
    for ((t = 0; t < 60000 && alive; t++)); do
        # Liveness first, the CSV second: the last row is always seen, even when the server exits
        # right after writing it (cpuacct counters outlive the processes).
        kill -0 "$server_pid" 2>/dev/null || alive=0
        shown=0
        [[ -f $work/run.csv ]] && shown=$(($(wc -l <"$work/run.csv") - 1))
        if [[ -z $at0m ]] && ((shown >= 1)); then
            at0c=$(cpuGroupSeconds "${clientGroups[@]}")
            at0m=$(cpuGroupSeconds master)
        fi
        if [[ -z $atEm ]] && ((shown >= nf - 1)); then
            atEc=$(cpuGroupSeconds "${clientGroups[@]}")
            atEm=$(cpuGroupSeconds master)
        fi
        ((alive)) && sleep 0.02
    done
    kill -0 "$server_pid" 2>/dev/null && { echo "scale-bench: run $n $mode did not end within 1200 s" >&2; return 1; }
    local status=0
    wait "$server_pid" || status=$?
    for ((i = 1; i <= n; i++)); do wait "${pids[i]}" 2>/dev/null || true; done
    pids=()
    if ((status != 0)) || [[ -z $at0m || -z $atEm ]]; then
        tail -n 20 "$work/server.log" >&2
        echo "scale-bench: run $n $mode failed (status $status)" >&2
        return 1
    fi
    local linkBytes=0
    for ((i = 1; i <= n; i++)); do
        linkBytes=$((linkBytes + $(netnsTxBytes "c$i")))
    done
    netnsTeardown
    local err=""
    ((scale == 1)) && err=$("$compare_bin" --csv --layer caustic_filtered "$work/run.exr" "$ref" | awk -F, 'NR == 2 { print $6 }')
    # CSV: frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,sets_total,deadline_hit,master_ms
    awk -F, -v scene="$scene" -v mode="$mode" -v n="$n" -v w="$w" -v h="$h" -v m="$m" -v cc="$clientCores" \
        -v mc="$masterCores" -v nf="$nf" -v m0="$at0m" -v m1="$atEm" -v c0="$at0c" -v c1="$atEc" \
        -v err="$err" -v load="$load" -v link="$linkBytes" '
        NR == 1 { next }
        { rows++; fps = $2; ph = $3 * $9; inc += ($8 < $9 || $10 != 0); msum += $11
          if (rows > 1) { bytes += $5; later++ } }
        END { printf "%s,%s,%d,%d,%d,%d,%s,%s,%d,%.3f,%.4f,%.4f,%.0f,%.0f,%s,%d,%s,%.0f,%.2f\n",
                  scene, mode, n, w, h, m, cc, mc, rows, fps, (c1 - c0) / (rows - 2), (m1 - m0) / (rows - 2),
                  bytes / later, ph, err, inc, load, link / rows, msum / rows }' "$work/run.csv" >>"$out/scale.csv"
    echo "  [$(date +%T) load $load] $scene $mode $n clients: $(tail -n 1 "$out/scale.csv")" >&2
}

echo "scene,mode,clients,width,height,M,client_cores,master_cores,frames,fps,client_cpu_s_per_frame,master_cpu_s_per_frame,bytes_per_frame,photons_total,caustic_rel_rmse,incomplete,load1,client_link_bytes_per_frame,master_ms" \
    >"$out/scale.csv"
machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'); load at start:$(uptime | sed 's/.*load average://')"
t0=$SECONDS
for mode in interaction walkthrough; do
    for n in $clientCounts; do run "$n" "$mode"; done
done
# Calibration for the model: the largest cluster again at twice the width and height, so fixed
# and per-pixel costs of the master and the clients can be told apart (its error column is
# against a reference of the base size, so it is left empty).
maxN=$(tr ' ' '\n' <<<"$clientCounts" | sort -n | tail -n 1)
run "$maxN" walkthrough 2
echo "scale-bench: runs took $((SECONDS - t0)) s; load at end:$(uptime | sed 's/.*load average://')" >&2
/usr/bin/python3 "$root/deploy/scale-bench.py" --csv "$out/scale.csv" --png "$out/scale.png" \
    --machine "$machine" --command "deploy/scale-bench.sh --clients \"$clientCounts\" --scene $scene --size $size -M $m --client-cores $clientCores --master-cores $masterCores --frames $frames --walk-frames $walkFrames --walk-photons $walkPhotons" \
    >"$out/scale.md"
cat "$out/scale.md"
echo "scale-bench: wrote $out/scale.csv, $out/scale.md, $out/scale.png" >&2
