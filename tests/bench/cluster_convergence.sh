#!/usr/bin/env bash
# Error against time of the cluster as shipped: rtpm-server and two rtpm-client processes on this
# machine (render threads per client as deploy/run-local.sh gives them), the default
# settings (M 3, P 20 000, still frames held to the 16.7 ms budget), on the curved-mirror scene with
# its closed-form reference (tests/support/ring_mirror.h; no photon estimator in the reference).
# One cluster per frame count; the time is the whole run's wall clock, from starting the server
# to the image written (start-up, scene transfer and BVH builds included), and the CPU seconds of
# all three processes. The error is the caustic-region rel. MAE of the caustic as shown
# (caustic_filtered) against the reference.
#
#   tests/bench/cluster_convergence.sh [--build DIR] [--estimator E ...] [--frames "1 2 4 ..."]
#                                      [--size WxH] [--clients N] [--repeat R]
#                                      [--pov "PHOTONS:GMIN:GMAX,..."] [--light X,Y,Z] [--ring-height H]
#                                      [-- extra rtpm-server flags]
#
# Prints one markdown row per frame count and, per estimator, the first measured time at which the
# error is at most 0.05 and 0.02. With --repeat R each frame count runs R times and the row gives
# the median wall and CPU time and the median error (a still view's photons depend on how its
# frames met the budget, so the error varies a little from run to run); whole runs of a quarter
# of a second vary by ±20 % on this machine, so a single run says little about a 10 % change.
# The repeats take turns (every frame count once, then again), so a machine that slows down for a
# minute slows every row alike.
# --pov: POV-Ray 3.7 renders the same scene (tests/bench/pov_compare.py's SDL and scoring: its
# photon render minus the render without photons) at each PHOTONS count and gather MIN:MAX, whole
# processes timed, once in every turn beside the clusters; prints its rows and the ratio of each
# estimator's first time at 0.05 and 0.02 to the least median time of a POV-Ray setting at that
# error (pov_compare.py finds its best settings: 10:50 at 250 000–500 000 photons for 0.05).
# --light, --ring-height: a variant of the scene (ring_mirror_bench's options), for the clusters,
# POV-Ray and the reference alike.
# Render threads per client: $RTPM_BENCH_THREADS if set.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
source "$root/deploy/paths.sh"
build=$root/build
estimators=(progressive knn)
frames="1 2 4 8 16 32 64 128 256"
size=320x240
clients=2
repeat=1
pov=""
variant=()
extra=()
while (($#)); do
    case $1 in
        --build) build=${2:?}; shift 2 ;;
        --estimator) estimators=(${2:?}); shift 2 ;;
        --frames) frames=${2:?}; shift 2 ;;
        --size) size=${2:?}; shift 2 ;;
        --clients) clients=${2:?}; shift 2 ;;
        --repeat) repeat=${2:?}; shift 2 ;;
        --pov) pov=${2:?}; shift 2 ;;
        --light | --ring-height) variant+=("$1" "${2:?}"); shift 2 ;;
        --) shift; extra=("$@"); break ;;
        *) echo "cluster_convergence.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done
[[ $repeat =~ ^[1-9][0-9]*$ ]] || { echo "cluster_convergence.sh: --repeat must be a positive whole number, not '$repeat'" >&2; exit 2; }
server_bin=$build/server/rtpm-server
client_bin=$build/client/rtpm-client
bench_bin=$build/tests/bench/ring_mirror_bench
for b in "$server_bin" "$client_bin" "$bench_bin"; do
    [[ -x $b ]] || { echo "cluster_convergence.sh: $b not built" >&2; exit 1; }
done
povSettings=()
if [[ -n $pov ]]; then
    IFS=, read -r -a povSettings <<<"$pov"
    for setting in "${povSettings[@]}"; do
        [[ $setting =~ ^[1-9][0-9]*:[1-9][0-9]*:[1-9][0-9]*$ ]] ||
            { echo "cluster_convergence.sh: --pov takes PHOTONS:GMIN:GMAX[,...] (e.g. 500000:10:50), not '$setting'" >&2; exit 2; }
    done
    command -v povray >/dev/null || { echo "cluster_convergence.sh: --pov needs povray (apt-get install povray)" >&2; exit 1; }
fi
width=${size%x*}
height=${size#*x}
threads=${RTPM_BENCH_THREADS:-$(rtpmClientThreads "$clients")}

work=$(mktemp -d /tmp/rtpm-convergence.XXXXXX)
pids=()
cleanup() {
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    rm -rf "$work"
}
trap cleanup EXIT
"$bench_bin" --write-scene "$work/mirror.glb" "${variant[@]}" >/dev/null
export RTPM_TOKEN
RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')

# cluster ESTIMATOR FRAMES DIR: one cluster run to its end, its image in DIR/out.exr.
cluster() {
    local estimator=$1 n=$2 dir=$3
    "$server_bin" --listen 127.0.0.1 --port 0 --port-file "$dir/port" --min-clients "$clients" \
        --scene "$work/mirror.glb" --photon-depth 2 --diffuse-bounces 0 --width "$width" --height "$height" \
        --estimator "$estimator" --frames "$n" --quiet --out "$dir/out.exr" "${extra[@]}" >"$dir/server.log" 2>&1 &
    local server=$!
    pids=("$server")
    # The clients start beside the server, as deploy/run-local.sh starts them (they read the
    # port file until the server has written it).
    for ((c = 1; c <= clients; c++)); do
        "$client_bin" --port-file "$dir/port" --name "bench-$c" --threads "$threads" >"$dir/client-$c.log" 2>&1 &
        pids+=("$!")
    done
    local status=0
    wait "$server" || status=$?
    for p in "${pids[@]:1}"; do wait "$p" || true; done
    pids=()
    ((status == 0)) || { cat "$dir/server.log" >&2; echo "cluster_convergence.sh: rtpm-server exited $status" >&2; exit 1; }
}

# run ESTIMATOR FRAMES: prints "wall cpu rel_mae energy" (wall: the whole run; CPU: user + system
# seconds of the server and the clients, all reaped by the run).
run() {
    local estimator=$1 n=$2 dir="$work/$1-$2"
    rm -rf "$dir"
    mkdir -p "$dir"
    local TIMEFORMAT='%R %U %S'
    { time cluster "$estimator" "$n" "$dir"; } 2>"$dir/time"
    local wall user sys _ err energy
    read -r wall user sys <"$dir/time"
    read -r _ err _ energy < <("$bench_bin" --compare "$dir/out.exr" --layer caustic_filtered "${variant[@]}")
    echo "$wall $(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }') $err $energy"
}

# POV-Ray, as tests/bench/pov_compare.py renders and scores it: the scene's SDL, the render
# without photons once (the caustic is the photon render minus it).
if ((${#povSettings[@]})); then
    light=0.55,0.9,0 ringHeight=0.35
    for ((i = 0; i < ${#variant[@]}; i += 2)); do
        case ${variant[i]} in --light) light=${variant[i + 1]} ;; --ring-height) ringHeight=${variant[i + 1]} ;; esac
    done
    /usr/bin/python3 -c 'import sys; sys.path.insert(0, sys.argv[1]); import pov_compare as p
print(p.sdl(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5]), end="")' \
        "$root/tests/bench" "$width" "$height" "$light" "$ringHeight" >"$work/ring_mirror.pov"
    povCommand=(povray "+I$work/ring_mirror.pov" +FE "+W$width" "+H$height" -A -D +WT2)
    "${povCommand[@]}" "+O$work/direct.exr" Declare=UsePhotons=0 >"$work/pov.log" 2>&1 ||
        { cat "$work/pov.log" >&2; echo "cluster_convergence.sh: povray failed" >&2; exit 1; }
fi

# povRun PHOTONS GMIN GMAX: prints "wall cpu rel_mae energy" of one POV-Ray process.
povRun() {
    local img="$work/pov-$1-$2-$3.exr"
    local TIMEFORMAT='%R %U %S'
    { time "${povCommand[@]}" "+O$img" "Declare=PhotonCount=$1" "Declare=GatherMin=$2" "Declare=GatherMax=$3" \
        >"$work/pov.log" 2>&1; } 2>"$work/pov.time" ||
        { cat "$work/pov.log" >&2; echo "cluster_convergence.sh: povray failed" >&2; exit 1; }
    local wall user sys _ err energy
    read -r wall user sys <"$work/pov.time"
    read -r _ err _ energy < <("$bench_bin" --compare "$img" --minus "$work/direct.exr" "${variant[@]}")
    echo "$wall $(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }') $err $energy"
}

# median: the median of each of the four columns of the lines on stdin (the middle run for an odd
# count, the upper middle otherwise), printed as the runs printed them.
median() {
    awk '
        { for (c = 1; c <= 4; c++) v[c, NR] = $c }
        END {
            m = int(NR / 2) + 1
            for (c = 1; c <= 4; c++) {
                for (i = 1; i <= NR; i++) col[i] = v[c, i]
                for (i = 2; i <= NR; i++)
                    for (j = i; j > 1 && col[j - 1] + 0 > col[j] + 0; j--) { t = col[j]; col[j] = col[j - 1]; col[j - 1] = t }
                printf "%s%s", col[m], (c < 4 ? " " : "\n")
            }
        }'
}

# runs[KEY]: every turn's run of KEY ("pov:SETTING" or "ESTIMATOR:FRAMES"), one line each:
# "wall cpu rel_mae energy".
declare -A runs
for ((r = 0; r < repeat; r++)); do
    for setting in "${povSettings[@]}"; do
        IFS=: read -r photons gmin gmax <<<"$setting"
        runs[pov:$setting]+="$(povRun "$photons" "$gmin" "$gmax")"$'\n'
    done
    for estimator in "${estimators[@]}"; do
        for n in $frames; do runs[$estimator:$n]+="$(run "$estimator" "$n")"$'\n'; done
    done
done

echo "| estimator | frames | wall s | CPU s (all processes) | caustic rel. MAE | energy |"
echo "|---|---|---|---|---|---|"
declare -A povBest  # target -> "wall setting": POV-Ray's least median wall time at that error
for setting in "${povSettings[@]}"; do
    read -r wall cpu err energy < <(printf '%s' "${runs[pov:$setting]}" | median)
    IFS=: read -r photons gmin gmax <<<"$setting"
    echo "| POV-Ray gather $gmin,$gmax | $photons photons | $wall | $cpu | $err | $energy |"
    for target in 0.05 0.02; do
        awk -v e="$err" -v t="$target" 'BEGIN { exit !(e <= t) }' || continue
        if [[ -z ${povBest[$target]:-} ]] || awk -v a="$wall" -v b="${povBest[$target]%% *}" 'BEGIN { exit !(a < b) }'; then
            povBest[$target]="$wall $setting"
        fi
    done
done
for estimator in "${estimators[@]}"; do
    declare -A first=()
    for n in $frames; do
        read -r wall cpu err energy < <(printf '%s' "${runs[$estimator:$n]}" | median)
        echo "| $estimator | $n | $wall | $cpu | $err | $energy |"
        for target in 0.05 0.02; do
            [[ -z ${first[$target]:-} ]] && awk -v e="$err" -v t="$target" 'BEGIN { exit !(e <= t) }' &&
                first[$target]="$wall"$'\t'"$n"
        done
    done
    for target in 0.05 0.02; do
        line="$estimator: first run at rel. MAE <= $target: "
        if [[ -n ${first[$target]:-} ]]; then
            line+="${first[$target]%$'\t'*} s (${first[$target]#*$'\t'} frames)"
            if [[ -n ${povBest[$target]:-} ]]; then
                line+=", $(awk -v a="${first[$target]%$'\t'*}" -v b="${povBest[$target]%% *}" 'BEGIN { printf "%.2f", a / b }')"
                line+=" of POV-Ray's ${povBest[$target]%% *} s (${povBest[$target]#* })"
            fi
        else
            line+="none"
        fi
        echo "$line" >&2
    done
    unset first
done
if ((${#povSettings[@]})); then
    for target in 0.05 0.02; do
        [[ -n ${povBest[$target]:-} ]] || echo "POV-Ray: no setting reached rel. MAE $target" >&2
    done
fi
