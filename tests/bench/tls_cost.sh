#!/usr/bin/env bash
# Cost of TLS on the cluster link: the same run with and without --tls-cert/--tls, alternating,
# prints fps (the server's summary) and user+system CPU seconds of the server and of the clients.
#
#   tests/bench/tls_cost.sh [--size WxH] [--frames N] [BUILD_DIR] [ROUNDS] [extra rtpm-server flags ...]
#
# Defaults: build/, 2 rounds, RING 640x480, 40 frames, 2 clients with 1 render thread each,
# walkthrough (frame 0 shoots, later frames only trace: the link's share of a frame is largest).
# Run it with --encoding float32 (24 B/px, 7.4 MB per frame) and rgb9e5-zstd (the default).
set -euo pipefail
size=640x480 frames=40
while (($#)); do
    case $1 in
        --size) size=${2:?--size needs WxH}; shift 2 ;;
        --frames) frames=${2:?--frames needs a count}; shift 2 ;;
        *) break ;;
    esac
done
build=${1:-build}
rounds=${2:-2}
shift $(( $# > 2 ? 2 : $# )) || true
extra=("$@")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -days 1 -subj /CN=rtpm-bench \
    -addext subjectAltName=IP:127.0.0.1 -keyout "$work/key.pem" -out "$work/cert.pem" 2>/dev/null
RTPM_TOKEN=$(openssl rand -hex 16)
export RTPM_TOKEN

run() {  # run LABEL tls(0/1)
    local label=$1 tls=$2 sflags=() cflags=()
    if ((tls)); then
        sflags=(--tls-cert "$work/cert.pem" --tls-key "$work/key.pem")
        cflags=(--tls --tls-ca "$work/cert.pem")
    fi
    rm -f "$work/port"
    /usr/bin/time -f "%U %S" -o "$work/server.time" "$build/server/rtpm-server" --port 0 --port-file "$work/port" \
        --scene RING --width "${size%x*}" --height "${size#*x}" --frames "$frames" --min-clients 2 --walkthrough --quiet \
        --out "$work/out.exr" "${sflags[@]}" "${extra[@]}" >"$work/server.out" 2>"$work/server.err" &
    local spid=$!
    for _ in $(seq 1 600); do [[ -s $work/port ]] && break; sleep 0.05; done
    local cpids=()
    for i in 1 2; do
        /usr/bin/time -f "%U %S" -o "$work/client$i.time" "$build/client/rtpm-client" --host 127.0.0.1 \
            --port-file "$work/port" --threads 1 "${cflags[@]}" >/dev/null 2>"$work/client$i.err" &
        cpids+=($!)
    done
    wait "$spid"
    for p in "${cpids[@]}"; do wait "$p"; done
    local fps server clients
    fps=$(sed -n 's/.*= \([0-9.]*\) fps.*/\1/p' "$work/server.out")
    server=$(awk '{printf "%.2f", $1 + $2}' "$work/server.time")
    clients=$(cat "$work/client1.time" "$work/client2.time" | awk '{s += $1 + $2} END {printf "%.2f", s}')
    printf '| %s | %s | %s | %s | %s |\n' "$label" "$fps" "$server" "$clients" "$(cut -d' ' -f1-3 /proc/loadavg)"
}

echo "| link | fps | server CPU s | clients CPU s | load 1/5/15 min |"
echo "|---|---|---|---|---|"
for _ in $(seq 1 "$rounds"); do
    run plain 0
    run TLS 1
done
