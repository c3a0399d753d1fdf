#!/usr/bin/env bash
# Speed next to error (DESIGN §8): renders RING at 160x120 with several photon budgets and frame
# counts, and prints each run's per-frame time beside its error against the stored converged
# reference (tests/data/reference/ring_160x120.exr), as CSV.
#   tests/accuracy/speed_vs_error.sh [build-dir] > speed_vs_error.csv
# Extra rtpm-render flags may follow the build dir (e.g. --no-spt, --threads 1).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-${RTPM_BUILD_DIR:-$root/build}}
shift || true
render="$build/common/rtpm-render"
compare="$build/common/rtpm-compare"
ref="$root/tests/data/reference/ring_160x120.exr"
for exe in "$render" "$compare"; do
    [[ -x "$exe" ]] || { echo "speed_vs_error.sh: $exe not built" >&2; exit 1; }
done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "paths_per_set_frame,frames,mean_frame_ms,mean_shoot_ms,mean_eye_ms,photons,caustic_rel_rmse,caustic_rel_mae,image_rel_rmse,energy_ratio"
for photons in 5000 20000 80000; do
    for frames in 1 4 16; do
        rm -f "$tmp/t.csv"
        "$render" --scene RING --width 160 --height 120 --photons "$photons" --frames "$frames" \
            --csv "$tmp/t.csv" --out "$tmp/t.exr" "$@" > /dev/null
        # frame,mode,shoot_ms,eye_ms,filter_ms,total_ms,photons,paths
        timing=$(awk -F, 'NR > 1 { s += $3; e += $4; t += $6; n++; p = $7 }
                          END { printf "%.1f,%.1f,%.1f,%d", t / n, s / n, e / n, p }' "$tmp/t.csv")
        # layer,width,height,threshold,caustic_pixels,caustic_rel_rmse,caustic_mae,caustic_rel_mae,
        # image_rel_rmse,image_mae,image_rel_mae,energy_ratio,...
        err=$("$compare" "$tmp/t.exr" "$ref" --csv | awk -F, 'NR == 2 { printf "%.4f,%.4f,%.4f,%.4f", $6, $8, $9, $12 }')
        echo "$photons,$frames,$timing,$err"
    done
done
