#!/usr/bin/env bash
# Runs a whole rtpm cluster on this machine: one rtpm-server and N rtpm-client processes.
#
#   deploy/run-local.sh --clients N --scene NAME [--view] [any rtpm-server flag ...]
#
# --view runs the cluster as a service with the browser viewer (rtpm-server --http 127.0.0.1:0,
# rendering until Ctrl-C) and prints the viewer's URL with the token; without it the server
# renders --frames frames (120 unless given: about two seconds of a still view held to the
# 16.7 ms frame budget) and exits.
# Builds first (deploy/build.sh, incremental, into ${RTPM_BUILD_DIR:-build}): only what the two
# programs need (RTPM_BUILD_SCOPE=programs: install-deps.sh build, and a new build folder is
# configured without tests and benchmarks; deploy/test.sh adds them later).
# The server listens on an ephemeral port (--port 0) and announces it through a port file; the
# clients start with it and connect once that file exists (they poll it; no sleep-as-readiness).
# The token is $RTPM_TOKEN, or a fresh random one. Each client gets twice its share of the cores
# in render threads (at least 1, at most all: deploy/paths.sh rtpmClientThreads), so a client
# whose sets are done lends its core to one still rendering (override: RTPM_CLIENT_THREADS).
# By default the server writes out/<scene>.exr and out/<scene>.png (relative to the current
# directory). At the end the per-frame figures are printed as a table. Every process this
# script started is stopped on exit, Ctrl-C or TERM. Exit status: the server's.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/deploy/paths.sh"
build=${RTPM_BUILD_DIR:-$root/build}
clients=2
scene=RING
server_args=()
user_csv=""
view=0

usage() {
    sed -n '2,18p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
}

while (($#)); do
    case $1 in
        --clients) clients=${2:?--clients needs a number}; shift 2 ;;
        --clients=*) clients=${1#*=}; shift ;;
        --scene) scene=${2:?--scene needs a name or file}; shift 2 ;;
        --scene=*) scene=${1#*=}; shift ;;
        --csv) user_csv=${2:?--csv needs a file}; shift 2 ;;
        --csv=*) user_csv=${1#*=}; shift ;;
        --view) view=1; shift ;;
        -h|--help) usage; exit 0 ;;
        *) server_args+=("$1"); shift ;;
    esac
done
if ! [[ $clients =~ ^[0-9]+$ ]] || ((clients < 1)); then
    echo "run-local.sh: --clients must be a positive integer, got '$clients'" >&2
    exit 2
fi

server_bin=$build/server/rtpm-server
client_bin=$build/client/rtpm-client
# Always (incrementally) build, so the server and clients never run stale binaries.
echo "run-local.sh: building rtpm-server and rtpm-client into $build" >&2
RTPM_BUILD_DIR=$build RTPM_BUILD_SCOPE=programs RTPM_BUILD_TARGETS="rtpm-server rtpm-client" \
    bash "$root/deploy/build.sh" >&2

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-local.XXXXXX")
pids=()
cleanup() {
    local status=$?
    trap - EXIT INT TERM
    # The server first: it finishes the frames in flight, writes the last image and says Bye to
    # the clients, which then exit by themselves.
    if [[ -n ${server_pid:-} ]] && kill -0 "$server_pid" 2>/dev/null; then
        kill "$server_pid" 2>/dev/null || true
        for ((i = 0; i < 300; i++)); do kill -0 "$server_pid" 2>/dev/null || break; sleep 0.1; done
    fi
    for pid in "${pids[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${pids[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    rm -rf "$work"
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if [[ -z ${RTPM_TOKEN:-} ]]; then
    RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
fi
export RTPM_TOKEN

csv=${user_csv:-$work/stats.csv}
port_file=$work/port
view_args=()
if ((view)); then
    has_http=0
    for a in "${server_args[@]}"; do [[ $a == --http || $a == --http=* ]] && has_http=1; done
    ((has_http)) || view_args=(--http 127.0.0.1:0)
else
    has_frames=0
    for a in "${server_args[@]}"; do [[ $a == --frames || $a == --frames=* ]] && has_frames=1; done
    ((has_frames)) || view_args=(--frames 120)
fi
server_out=$work/server.out
# Server and clients run in their own sessions: Ctrl-C reaches this script alone, whose cleanup
# signals the server once (a second signal would make it stop without finishing its frame).
setsid "$server_bin" --port 0 --port-file "$port_file" --min-clients "$clients" --scene "$scene" --csv "$csv" \
    "${view_args[@]}" "${server_args[@]}" > >(trap '' INT TERM; exec tee "$server_out") &
server_pid=$!
pids+=("$server_pid")

# The clients start beside the server: each reads the port file every 2 ms until the server has
# written it (rtpm-client --port-file), so they connect as soon as it listens, their own start-up
# (about 6 ms each) overlapping the server's. Waiting for the file here first added this loop's
# poll and the clients' start to every run.
threads=${RTPM_CLIENT_THREADS:-$(rtpmClientThreads "$clients")}
for ((c = 1; c <= clients; c++)); do
    setsid "$client_bin" --port-file "$port_file" --name "local-$c" --threads "$threads" \
        >"$work/client-$c.log" 2>&1 &
    pids+=("$!")
done

# Readiness (for the viewer's URL, and a server that fails to start): the port file appears
# (atomically) once the server listens. Bounded poll.
for ((i = 0; i < 600; i++)); do
    [[ -s $port_file ]] && break
    if ! kill -0 "$server_pid" 2>/dev/null; then
        wait "$server_pid" && status=0 || status=$?
        echo "run-local.sh: rtpm-server exited (status $status) before listening" >&2
        exit "${status:-1}"
    fi
    sleep 0.05
done
if [[ ! -s $port_file ]]; then
    echo "run-local.sh: rtpm-server did not write its port file within 30 s" >&2
    exit 1
fi

if ((view)); then
    url=""
    for ((i = 0; i < 600; i++)); do
        url=$(sed -n 's/^viewer: \(http:[^ ]*\)$/\1/p' "$server_out" | head -n 1)
        [[ -n $url ]] && break
        sleep 0.05
    done
    if [[ -z $url ]]; then
        echo "run-local.sh: rtpm-server printed no viewer URL" >&2
        exit 1
    fi
    echo
    echo "run-local.sh: open ${url}#token=${RTPM_TOKEN}   (rendering until Ctrl-C)"
    echo
fi

status=0
wait "$server_pid" || status=$?
# The server said Bye to every client; give them their normal exit, the trap reaps the rest.
for ((c = 1; c <= clients; c++)); do
    if ((status != 0)); then
        echo "--- client $c log ---" >&2
        tail -n 5 "$work/client-$c.log" >&2 || true
    fi
done

if [[ -s $csv ]]; then
    echo
    echo "per-frame figures ($csv):"
    if command -v column >/dev/null; then
        column -t -s, "$csv"
    else
        cat "$csv"
    fi
fi
exit "$status"
