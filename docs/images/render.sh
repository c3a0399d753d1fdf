#!/usr/bin/env bash
# Renders the documentation's pictures with rtpm-render at its default settings and prints each
# command with its wall time:
#   readme  README's RING and GLASS at 640×480 → docs/images/ring.png, glass.png
#   scenes  docs/SCENES.md's page at 320×240 → docs/images/scenes/*.png: the five built-in scenes,
#           the glTF corpus of tests/data/gltf/corpus (shaped like Blender's exports, most without
#           light or camera: what a user gets from `--scene file.gltf` alone) and two with --env
#
#   docs/images/render.sh [--build DIR] [readme|scenes ...]   (default DIR: build; default: both)
#
# Only --scene (and --env), the size and --frames are given: everything else is what a user gets.
# The PNG is the one rtpm-render writes (tone-mapped, auto exposure); when oiiotool is present it
# is re-compressed losslessly (same pixels, about two thirds of the size). The EXRs are left in a
# temporary folder that is removed at exit.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$root/build
sets=()
while (($#)); do
    case $1 in
        --build) build=${2:?--build needs a folder}; shift 2 ;;
        --build=*) build=${1#*=}; shift ;;
        readme|scenes) sets+=("$1"); shift ;;
        -h|--help) sed -n '2,15p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "render.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
((${#sets[@]})) || sets=(readme scenes)
render=$build/common/cmd/rtpm-render
if [[ ! -x $render ]]; then
    echo "render.sh: $render not found: build it first (cmake --build $build --target rtpm-render)" >&2
    exit 1
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-images.XXXXXX")
trap 'rm -rf "$work"' EXIT

# picture NAME DEST_DIR rtpm-render-arguments...: renders, re-compresses, prints the command.
picture() {
    local name=$1 dest=$2
    shift 2
    local start end
    start=$(date +%s.%N)
    if ! "$render" "$@" --out "$work/$name.exr" >"$work/$name.log" 2>&1; then
        tail -n 5 "$work/$name.log" >&2
        echo "render.sh: rtpm-render $* failed" >&2
        exit 1
    fi
    end=$(date +%s.%N)
    mkdir -p "$dest"
    if command -v oiiotool >/dev/null; then
        oiiotool "$work/$name.png" -o:compression=9 "$dest/$name.png"
    else
        cp "$work/$name.png" "$dest/$name.png"
    fi
    local args="$*"
    printf 'rtpm-render %s: %.1f s wall, %s bytes -> %s\n' "${args//"$root"\//}" \
        "$(awk -v a="$start" -v b="$end" 'BEGIN { print b - a }')" "$(stat -c %s "$dest/$name.png")" \
        "${dest#"$root"/}/$name.png"
}

for set in "${sets[@]}"; do
    if [[ $set == readme ]]; then
        # scene, frames: enough still frames for a clean caustic in a few seconds on two cores
        # (still frames held to the 16.7 ms budget: three times the frames a 50 ms budget took).
        for job in "RING 48" "GLASS 96"; do
            read -r scene frames <<<"$job"
            picture "$(tr '[:upper:]' '[:lower:]' <<<"$scene")" "$root/docs/images" \
                --scene "$scene" --width 640 --height 480 --frames "$frames"
        done
    else
        out=$root/docs/images/scenes
        corpus=tests/data/gltf/corpus
        for scene in RING GLASS EGG HEADLIGHT CORNELL; do
            picture "$(tr '[:upper:]' '[:lower:]' <<<"$scene")" "$out" \
                --scene "$scene" --width 320 --height 240 --frames 48
        done
        for file in box metal_sphere no_material glass_on_floor rough_ring still_life; do
            picture "$file" "$out" --scene "$root/$corpus/$file.gltf" --width 320 --height 240 --frames 48
        done
        picture still_life_sun "$out" --scene "$root/$corpus/still_life.gltf" \
            --env "$root/$corpus/sun_sky.hdr" --width 320 --height 240 --frames 48
        picture glass_sun "$out" --scene GLASS --env "$root/$corpus/sun_sky.hdr" \
            --width 320 --height 240 --frames 48
    fi
done
