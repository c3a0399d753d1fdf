#!/usr/bin/env bash
# Installs every Debian 12 package that rtpm's build, tests and benchmarks need. Idempotent.
set -euo pipefail

packages=(
    build-essential cmake ninja-build pkg-config git
    libembree-dev libtbb-dev libglm-dev
    libopenimageio-dev libopenexr-dev openimageio-tools
    libasio-dev
    libtinygltf-dev nlohmann-json3-dev libstb-dev libtinyobjloader-dev
    libcli11-dev libspdlog-dev libfmt-dev
    libgtest-dev libgmock-dev libbenchmark-dev libnanoflann-dev
    libzstd-dev
    clang libclang-rt-14-dev
    python3 python3-matplotlib python3-numpy
    povray  # tests/bench/pov_compare.py: the offline photon-mapping peer (issue 9)
    iproute2 procps
)

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
    echo "install-deps: all ${#packages[@]} packages present"
    exit 0
fi

SUDO=""
[[ $(id -u) -ne 0 ]] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
