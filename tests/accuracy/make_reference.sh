#!/usr/bin/env bash
# Regenerates the stored converged RING reference used by tests/accuracy/ring_reference_test.cpp.
#
# Run by hand after a change that is meant to alter RING's caustic (never by a test):
#   tests/accuracy/make_reference.sh [build-dir]
# The reference is a 160x120 RING render with 10x the photons per batch and 10x the frames of the
# test's render (100x the photons) and k = 256, so its noise and its k-NN blur are both far below
# the test's; only the caustic layers are kept, as half floats (< 300 KB).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-${RTPM_BUILD_DIR:-$root/build}}
render="$build/common/cmd/rtpm-render"
out="$root/tests/data/reference/ring_160x120.exr"
[[ -x "$render" ]] || { echo "make_reference.sh: $render not built (cmake --build $build --target rtpm-render)" >&2; exit 1; }
command -v oiiotool >/dev/null || { echo "make_reference.sh: oiiotool (openimageio-tools) is needed" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# These settings are the reference's definition; ring_reference_test.cpp states them too.
"$render" --estimator knn --scene RING --width 160 --height 120 --interleave 3 --filter 3 \
    --photons 200000 --frames 40 --k 256 --cap 0 --out "$tmp/ring.exr"
oiiotool "$tmp/ring.exr" \
    --ch caustic.R,caustic.G,caustic.B,caustic_filtered.R,caustic_filtered.G,caustic_filtered.B \
    -d half --compression zip -o "$out"
# Its provenance beside it (tests/unit/image/reference_provenance_test.cpp checks the hash).
commit=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)
git -C "$root" diff --quiet HEAD 2>/dev/null || commit="$commit with uncommitted changes"
cat >"$out.provenance" <<PROVENANCE
# Provenance of $(basename "$out") (tests/unit/image/reference_provenance_test.cpp checks the hash).
file: $(basename "$out")
sha256: $(sha256sum "$out" | cut -d' ' -f1)
made: $(date -u +%F) by tests/accuracy/make_reference.sh at $commit
command: rtpm-render --estimator knn --scene RING --width 160 --height 120 --interleave 3 --filter 3 --photons 200000 --frames 40 --k 256 --cap 0, then oiiotool keeping caustic.RGB and caustic_filtered.RGB as half floats, zip
what: RING's caustic converged by rtpm itself (100x the photons of the test's render, k = 256): it shares the k-NN estimator's blur, so errors against it under-report; not an analytic reference
used by: tests/accuracy/ring_reference_test.cpp
PROVENANCE
ls -l "$out" "$out.provenance"
