#!/usr/bin/env bash
# Renders the README's pictures of RING and GLASS with rtpm-render at its default settings, into
# docs/images/ring.png and docs/images/glass.png, and prints each command with its wall time.
#
#   docs/images/render.sh [--build DIR]        (default DIR: build; needs rtpm-render built)
#
# Only --scene, the size and --frames are given: everything else is what a user gets. The PNG is
# the one rtpm-render writes (tone-mapped, auto exposure); when oiiotool is present it is
# re-compressed losslessly (same pixels, about two thirds of the size). The EXRs are left in a
# temporary folder that is removed at exit.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$root/build
while (($#)); do
    case $1 in
        --build) build=${2:?--build needs a folder}; shift 2 ;;
        --build=*) build=${1#*=}; shift ;;
        -h|--help) sed -n '2,10p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "render.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
render=$build/common/cmd/rtpm-render
if [[ ! -x $render ]]; then
    echo "render.sh: $render not found: build it first (cmake --build $build --target rtpm-render)" >&2
    exit 1
fi

out=$root/docs/images
work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-images.XXXXXX")
trap 'rm -rf "$work"' EXIT

# scene, frames: enough still frames for a clean caustic in a few seconds on two cores.
for job in "RING 16" "GLASS 32"; do
    read -r scene frames <<<"$job"
    name=$(tr '[:upper:]' '[:lower:]' <<<"$scene")
    args=(--scene "$scene" --width 640 --height 480 --frames "$frames")
    start=$(date +%s.%N)
    if ! "$render" "${args[@]}" --out "$work/$name.exr" >"$work/$name.log" 2>&1; then
        tail -n 5 "$work/$name.log" >&2
        echo "render.sh: rtpm-render ${args[*]} failed" >&2
        exit 1
    fi
    end=$(date +%s.%N)
    if command -v oiiotool >/dev/null; then
        oiiotool "$work/$name.png" -o:compression=9 "$out/$name.png"
    else
        cp "$work/$name.png" "$out/$name.png"
    fi
    printf 'rtpm-render %s: %.1f s wall, %s bytes -> docs/images/%s.png\n' \
        "${args[*]}" "$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')" "$(stat -c %s "$out/$name.png")" "$name"
done
