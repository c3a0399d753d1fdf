#!/usr/bin/env bash
# Multi-host test without Docker (ctest label `multihost`, root only): the master and every client
# on a host of its own — a network namespace joined to a switch namespace by a veth pair — with
# the links shaped as in the paper's set-up (§6): 100 Mbit/s per client, 1 Gbit/s master uplink,
# both directions (tc tbf). Checks that the run ends normally, every frame is complete, all pixel
# data crossed the shaped links, and the image has bit-identical pixels to rtpm-render's with the same
# settings (float32 pixels on the wire).
#
#   multihost_test.sh SERVER CLIENT RENDER COMPARE [CLIENTS] [FRAMES]
#
# Exit status: 0 passed, 1 failed, 77 skipped (not root, or this kernel/container refuses network
# namespaces): the reason is printed. Traffic stays on 10.213.0.0/16 inside the namespaces made
# here; namespaces, cgroups and processes are removed on every exit path; every wait is bounded.
set -euo pipefail

server_bin=${1:?usage: multihost_test.sh SERVER CLIENT RENDER COMPARE [CLIENTS] [FRAMES]}
client_bin=${2:?}
render_bin=${3:?}
compare_bin=${4:?}
clients=${5:-3}
frames=${6:-6}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$here/../../deploy/netns.sh"

if ! reason=$(netnsCheck); then
    echo "skipped: multihost test: $reason"
    exit 77
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-multihost.XXXXXX")
pids=()
cleanup() {
    local status=$?
    trap - EXIT INT TERM
    local p
    for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
    for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
    netnsTeardown
    if ((status != 0)); then
        for f in "$work"/*.log; do [[ -f $f ]] && { echo "--- $(basename "$f")"; tail -n 15 "$f"; }; done
    fi
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
fail() { echo "multihost: FAILED: $*" >&2; exit 1; }

# Topology: master 10.213.0.1 on a 1 Gbit/s uplink, client i 10.213.1.i on 100 Mbit/s.
netnsInit "rtpmmh$$"
netnsHost master 10.213.0.1 1gbit
for ((i = 1; i <= clients; i++)); do netnsHost "c$i" "10.213.1.$i" 100mbit; done
tc -n "$netnsPrefix-master" qdisc show dev eth0 | grep -q "rate 1Gbit" || fail "master uplink not shaped to 1 Gbit/s"
tc -n "$netnsPrefix-c1" qdisc show dev eth0 | grep -q "rate 100Mbit" || fail "client link not shaped to 100 Mbit/s"

# One batch per pass (--frame-budget-ms 0): pass sizes chosen from frame times would differ between
# the cluster and rtpm-render, and the two images with them.
settings=(--scene RING --width 160 --height 120 --interleave 3 --frames "$frames" --frame-budget-ms 0)
export RTPM_TOKEN
RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')

# The master listens on its namespace's address only; its port comes through a port file.
ip netns exec "$(netnsName master)" "$server_bin" --listen 10.213.0.1 --port 0 --port-file "$work/port" \
    --min-clients "$clients" --encoding float32 --deadline-ms 600000 --quiet \
    --csv "$work/frames.csv" --out "$work/cluster.exr" "${settings[@]}" >"$work/server.log" 2>&1 &
server_pid=$!
pids+=("$server_pid")
for ((i = 0; i < 600; i++)); do
    [[ -s $work/port ]] && break
    kill -0 "$server_pid" 2>/dev/null || fail "rtpm-server exited before listening"
    sleep 0.05
done
[[ -s $work/port ]] || fail "rtpm-server did not listen within 30 s"
port=$(cat "$work/port")

client_pids=()
for ((i = 1; i <= clients; i++)); do
    ip netns exec "$(netnsName "c$i")" "$client_bin" --server "10.213.0.1:$port" --name "host-$i" --threads 1 \
        --connect-timeout 30 >"$work/client-$i.log" 2>&1 &
    client_pids+=("$!")
    pids+=("$!")
done

# Meanwhile the reference, in this (the machine's own) namespace.
"$render_bin" "${settings[@]}" --out "$work/ref.exr" >"$work/render.log" 2>&1 || fail "rtpm-render failed"

# Bounded wait for the master.
for ((i = 0; i < 6000; i++)); do
    kill -0 "$server_pid" 2>/dev/null || break
    sleep 0.1
done
kill -0 "$server_pid" 2>/dev/null && fail "rtpm-server still running after 600 s"
status=0
wait "$server_pid" || status=$?
((status == 0)) || fail "rtpm-server exited with status $status"
for ((i = 0; i < clients; i++)); do
    status=0
    for ((t = 0; t < 200; t++)); do kill -0 "${client_pids[i]}" 2>/dev/null || break; sleep 0.1; done
    wait "${client_pids[i]}" || status=$?
    ((status == 0)) || fail "client $((i + 1)) exited with status $status"
done
pids=()

# Every frame complete (CSV: frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,
# sets_arrived,sets,deadline,…) and with photons.
rows=$(awk 'NR > 1' "$work/frames.csv" | wc -l)
((rows == frames)) || fail "$rows frames in the CSV, expected $frames"
bad=$(awk -F, 'NR > 1 && ($8 != $9 || $10 != 0 || $3 <= 0)' "$work/frames.csv" | wc -l)
((bad == 0)) || fail "$bad frames incomplete, shown at their deadline or without photons"
payload=$(awk -F, 'NR > 1 { s += $5 } END { printf "%.0f", s }' "$work/frames.csv")

# All pixel data crossed the shaped links: what the clients sent through their tbf queues covers
# the payload the master counted, and each client sent its share.
sent=0
for ((i = 1; i <= clients; i++)); do
    b=$(netnsTxBytes "c$i")
    ((b > payload / clients / 2)) || fail "client $i sent only $b bytes through its shaped link (payload $payload)"
    sent=$((sent + b))
done
((sent >= payload)) || fail "clients sent $sent bytes through their shaped links, less than the $payload bytes of pixels"
master_sent=$(netnsTxBytes master)
((master_sent > 0)) || fail "nothing left the master through its shaped uplink"

# The image: bit-identical pixels in every channel (the headers differ: each names the program that
# wrote it), and not trivially so — the caustic region of the reference is not empty and its error
# is exactly zero.
"$compare_bin" --identical "$work/cluster.exr" "$work/ref.exr" >/dev/null 2>"$work/identical.err" ||
    fail "the cluster's pixels differ from rtpm-render's: $(cat "$work/identical.err")"
"$compare_bin" --csv --layer caustic_filtered "$work/cluster.exr" "$work/ref.exr" >"$work/compare.csv" ||
    fail "rtpm-compare failed"
# CSV: layer,width,height,threshold,caustic_pixels,caustic_rel_rmse,…,energy_ratio,…
awk -F, 'NR == 2 { ok = $5 > 0 && $6 == "0" && $12 == "1" } END { exit !ok }' "$work/compare.csv" ||
    fail "rtpm-compare: no caustic region, or error not exactly zero: $(tail -n 1 "$work/compare.csv")"

echo "multihost: $clients clients on 100 Mbit/s links, master on 1 Gbit/s: $rows frames complete," \
    "$payload bytes of pixels ($sent sent by the clients, $master_sent by the master), pixels bit-identical to rtpm-render's"
