#!/usr/bin/env bash
# Installs the Debian 12 packages rtpm needs. Idempotent: does nothing when all are present.
#
#   deploy/install-deps.sh [GROUP ...]      (root or sudo; default group: dev)
#
#   dev       build, tests and benchmarks (compilers, -dev packages, GoogleTest, matplotlib, …)
#   build     only what building rtpm-server, rtpm-client and rtpm-render needs (Dockerfile's
#             build stage)
#   runtime   only the shared libraries those three programs load (Dockerfile's runtime stage)
#   docker    Docker engine, Compose 1.29 and debootstrap for deploy/compose-test.sh; iproute2
#             (ip netns, veth, tc) for the multihost test and deploy/scale-bench.sh
set -euo pipefail

build=(
    build-essential cmake ninja-build pkg-config
    libembree-dev libtbb-dev libglm-dev
    libopenexr-dev libstb-dev
    libasio-dev libwebsocketpp-dev libturbojpeg0-dev
    libtinygltf-dev nlohmann-json3-dev libtinyobjloader-dev
    libdraco-dev  # KHR_draco_mesh_compression (common/scene/gltf_draco.cpp)
    libcli11-dev
    libzstd-dev
    libssl-dev  # libcrypto: HMAC-SHA256 and nonces of the cluster handshake (proto/auth.h)
)
runtime=(
    libembree3-3 libtbb12 libopenexr-3-1-30 libstb0 libtinyobjloader2rc10 libzstd1
    libturbojpeg0 libssl3 libdraco7
)
dev=(
    "${build[@]}" git
    libopenimageio-dev openimageio-tools libwebp-dev libpng-dev
    libgtest-dev libgmock-dev libbenchmark-dev libnanoflann-dev
    clang libclang-rt-14-dev
    python3 python3-matplotlib python3-numpy
    povray  # tests/bench/pov_compare.py: the offline photon-mapping peer (issue 9)
    iproute2 procps
    linux-perf  # tests/bench/frame_profile.sh (the bench-smoke label runs it)
    openssl  # tests make throwaway TLS certificates; docs generate tokens with `openssl rand`
)
docker=(
    docker.io docker-compose debootstrap python3-jsonschema
    iproute2 procps ca-certificates
)

groups=("$@")
((${#groups[@]})) || groups=(dev)
packages=()
for g in "${groups[@]}"; do
    case $g in
        dev) packages+=("${dev[@]}") ;;
        build) packages+=("${build[@]}") ;;
        runtime) packages+=("${runtime[@]}") ;;
        docker) packages+=("${docker[@]}") ;;
        *) echo "install-deps: unknown group '$g' (dev, build, runtime, docker)" >&2; exit 2 ;;
    esac
done

missing=()
for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
    echo "install-deps: all ${#packages[@]} packages of ${groups[*]} present"
    exit 0
fi

SUDO=""
[[ $(id -u) -ne 0 ]] && SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
