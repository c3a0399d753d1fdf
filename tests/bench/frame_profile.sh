#!/usr/bin/env bash
# Where a frame's CPU goes, per built-in scene: rtpm-render on one thread under `perf record`,
# self time grouped into the phases of a client frame; prints one markdown table row per run.
#
#   tests/bench/frame_profile.sh [--mode interaction|walkthrough] [--estimator knn|progressive]
#                                [--frames N] [--size WxH] SCENE...
#
# interaction: every frame shoots P = 20 000 paths per set and, with knn, re-traces and gathers
#   every pixel (the frame of a light or material edit).
# walkthrough: frame 0 shoots 200 000 paths per set and the cap stops every later batch, so the
#   later frames only trace and gather (the frame of a moving camera; the image of frame 0 is
#   the same as the cluster's walkthrough map).
# Groups (self time, so a function's callees count in their own group): photon shooting
# (tracing, emission, QMC), kd-tree insertion, ray casting (Embree, eye pass and shooting
# alike: in walkthrough frames all of it is the eye pass), caustic gather (k-NN traversal,
# heap, occupancy test, progressive radius gathers), shading (eye paths, direct light, camera),
# box filter and composition, other. Writing the EXR/PNG at the end is left out of the total.
# Binaries: ${RTPM_BUILD_DIR:-<repo>/build}/common/cmd/rtpm-render (Release). Needs `perf` (exit
# status 77 without it).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${RTPM_BUILD_DIR:-$root/build}
render=$build/common/cmd/rtpm-render
mode=interaction estimator=knn frames=6 size=640x480
scenes=()
while (($#)); do
    case $1 in
        --mode) mode=$2; shift ;;
        --estimator) estimator=$2; shift ;;
        --frames) frames=$2; shift ;;
        --size) size=$2; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"; exit 0 ;;
        -*) echo "frame_profile.sh: unknown option '$1'" >&2; exit 2 ;;
        *) scenes+=("$1") ;;
    esac
    shift
done
((${#scenes[@]})) || scenes=(RING GLASS HEADLIGHT)
# Without perf, or where the kernel refuses to sample (perf_event_paranoid, a container), there is
# nothing to measure: exit 77, which the bench-smoke test reports as skipped.
command -v perf >/dev/null || { echo "frame_profile.sh: skipped: needs perf (Debian package linux-perf)" >&2; exit 77; }
perf record -q -o /dev/null -- true >/dev/null 2>&1 ||
    { echo "frame_profile.sh: skipped: perf cannot record here (kernel.perf_event_paranoid = $(cat /proc/sys/kernel/perf_event_paranoid 2>/dev/null || echo ?))" >&2; exit 77; }
[[ -x $render ]] || { echo "frame_profile.sh: no $render (build Release first)" >&2; exit 1; }
case $mode in
    interaction) extra=(-P 20000) ;;
    walkthrough) extra=(-P 200000 --cap 1) ;;
    *) echo "frame_profile.sh: --mode interaction|walkthrough" >&2; exit 2 ;;
esac
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "| scene | mode | estimator | frames | photon shooting | kd-tree insertion | ray casting (Embree) | caustic gather | shading + direct light | box filter, composition | other | CPU s (frames, one thread) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for scene in "${scenes[@]}"; do
    perf record -q -F 2000 -o "$work/perf.data" -- "$render" --scene "$scene" --estimator "$estimator" \
        --frames "$frames" --threads 1 --width "${size%x*}" --height "${size#*x}" "${extra[@]}" \
        --out "$work/out.exr" >"$work/log" 2>&1 || { cat "$work/log" >&2; exit 1; }
    perf report -i "$work/perf.data" --no-children --sort dso,sym --stdio -g none 2>/dev/null |
        awk -v scene="$scene" -v mode="$mode" -v est="$estimator" -v frames="$frames" '
        /^ +[0-9.]+%/ {
            pct = $1; sub(/%/, "", pct); line = $0
            g = "other"
            if (line ~ /libz|OpenEXR|Imf|stbi|libstb|libpng|writeImages|writeExr|writePng/) g = "output"
            else if (line ~ /libembree|EmbreeScene::(intersect|occluded|completeHit)|fillPacket/) g = "rays"
            else if (line ~ /searchKdNodes|gatherKnn|gatherGroup|__introselect|RadiusResultSet|KnnHeap|FrontFacingKnn|PhotonOccupancy|PhotonMaps::(radiance|gatherMap)|causticRadiance|ProgressiveSet/) g = "gather"
            else if (line ~ /KdTree::(insert|build|splitOverfull|relink|buildRange)|PhotonColumns|partition|memmove|memcpy/) g = "insert"
            else if (line ~ /tracePhoton|Halton|radicalInverse|sampleEmission|cosineDirection|PhotonMaps::(traceBatch|toStored|shoot)|Emitter|photon_tracer|hashKeys|mixBits|fresnel|refract|LightSequence|[Ss]pt[A-Z]|sincos|tanf/) g = "shoot"
            else if (line ~ /shadePixel|areaLight|punctualLight|directLight|rayDirection|renderSet|offsetOrigin|baseColorAt|AreaLightSampler|splitMix|hashToUnit|wrap01/) g = "shade"
            else if (line ~ /boxFilter|BoxFilter|FrameImage|compose|scatter|toneMap|slideRow/) g = "filter"
            sum[g] += pct
        }
        END {
            total = 100 - sum["output"]
            printf "| %s | %s | %s | %d", scene, mode, est, frames
            n = split("shoot insert rays gather shade filter other", order, " ")
            for (i = 1; i <= n; i++) printf " | %.0f %%", 100 * sum[order[i]] / total
            printf " | "
        }'
    # CPU seconds of the frames alone: samples outside image output at 2000 Hz.
    perf report -i "$work/perf.data" --no-children --sort dso --stdio -g none 2>/dev/null |
        awk '/^# Samples:/ { n = $3; if (n ~ /K$/) { sub(/K/, "", n); n *= 1000 } }
             /^ +[0-9.]+%/ && /libz|OpenEXR|libstb|libpng/ { pct = $1; sub(/%/, "", pct); out += pct }
             END { printf "%.2f |\n", n * (1 - out / 100) / 2000 }'
done
