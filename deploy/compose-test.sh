#!/usr/bin/env bash
# End-to-end test of the Docker deployment: the image, the compose file on one host, and the same
# file as a Swarm stack on a single-node swarm.
#
#   deploy/compose-test.sh [--programs BUILD_DIR] [--frames N] [--clients N] [--no-swarm]
#                          [--timeout SECONDS]
#
# 1. Docker engine: uses the running dockerd, or starts one (root) and stops it at the end. Prints
#    "skipped: no Docker engine (…)" and exits 77 (ctest's "skipped") when none runs and none can
#    be started: never 0, so a caller cannot mistake a skip for a pass (.ci/run fails on it).
# 2. Base image: debian:12 as present, else made by deploy/docker-base.sh (debootstrap).
# 3. Image: deploy/Dockerfile, every stage (compile included). With --programs BUILD_DIR the
#    programs built there (same Debian 12 packages, e.g. by CI's first stage) are put on the
#    Dockerfile's runtime-base stage instead, so CI compiles once.
# 4. Compose (`docker compose` when present, else Debian 12's `docker-compose` 1.29): the server
#    alone first, until Docker's own HEALTHCHECK reports it healthy; then --clients clients. The
#    server renders --frames frames of RING at 160×120 with exact float32 pixels and exits 0;
#    every frame in its CSV must be complete and its EXR's pixels must be bit-identical to the ones
#    rtpm-render writes in the same image with the same settings.
# 5. Swarm: `docker swarm init` (left again at the end when this script made it), `docker stack
#    deploy` of the same file with the same checks, `docker stack rm`.
# Everything it started (containers, volumes, networks, stack, swarm, the test image's tag,
# dockerd) is removed on exit; debian:12, rtpm:runtime-base and the layer cache stay for the next
# run. Every wait is
# bounded; the whole run is bounded by --timeout (default 1500 s). Exit status 0 = passed,
# 77 = skipped (no Docker engine), anything else = failed.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/deploy/paths.sh"
programs=""
frames=8
clients=3
swarm=1
budget=1500
while (($#)); do
    case $1 in
        --programs) programs=$(cd "${2:?--programs needs a build directory}" && pwd); shift 2 ;;
        --frames) frames=${2:?}; shift 2 ;;
        --clients) clients=${2:?}; shift 2 ;;
        --no-swarm) swarm=0; shift ;;
        --timeout) budget=${2:?}; shift 2 ;;
        -h|--help) sed -n '2,27p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "compose-test: unknown option '$1' (see --help)" >&2; exit 2 ;;
    esac
done

say() { echo "compose-test [$((SECONDS))s]: $*"; }
fail() { echo "compose-test: FAILED: $*" >&2; exit 1; }
# left: seconds of the budget still available (at least 1).
left() { local l=$((budget - SECONDS)); ((l > 0)) || fail "time budget of $budget s used up"; echo "$l"; }

work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-compose-test.XXXXXX")
project=rtpmtest$$
image=rtpm:compose-test-$$
# Kept between runs (it is the layer cache of --programs): the Dockerfile's runtime-base stage.
base_image=rtpm:runtime-base
started_dockerd=""
made_swarm=0
compose=()
skipped=0
cleanup() {
    local status=$?
    trap - EXIT INT TERM
    if ((${#compose[@]})); then
        "${compose[@]}" down -v --remove-orphans >/dev/null 2>&1 || true
    fi
    if docker info >/dev/null 2>&1; then
        docker stack rm "$project" >/dev/null 2>&1 || true
        # A stack's containers and its volume go away asynchronously: bounded wait, then remove.
        for ((i = 0; i < 60; i++)); do
            [[ -z $(docker ps -aq --filter "label=com.docker.stack.namespace=$project") ]] && break
            sleep 0.5
        done
        docker rm -f "$project-render" >/dev/null 2>&1 || true
        docker volume rm "${project}_out" >/dev/null 2>&1 || true
        ((made_swarm)) && docker swarm leave --force >/dev/null 2>&1 || true
        docker image rm "$image" >/dev/null 2>&1 || true
    fi
    if [[ -n $started_dockerd ]]; then
        kill "$started_dockerd" 2>/dev/null || true
        for ((i = 0; i < 100; i++)); do kill -0 "$started_dockerd" 2>/dev/null || break; sleep 0.1; done
    fi
    rm -rf "$work"
    if ((status != 0 && !skipped)); then
        echo "compose-test: exit status $status" >&2
    elif ((!skipped)); then
        say "passed"
    fi
    exit "$status"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# --- 1. Docker engine ---------------------------------------------------------------------------
if [[ $(id -u) -eq 0 ]]; then
    bash "$root/deploy/install-deps.sh" docker >/dev/null
fi
skip() {
    echo "skipped: no Docker engine ($1)"
    skipped=1
    exit 77
}
command -v docker >/dev/null || skip "no docker command, and not root to install docker.io"
if ! docker info >/dev/null 2>&1; then
    if [[ -S /var/run/docker.sock ]] && pgrep -x dockerd >/dev/null; then
        skip "dockerd runs but does not answer this user: $(docker info 2>&1 >/dev/null | head -n 1)"
    fi
    if [[ $(id -u) -ne 0 ]] || ! command -v dockerd >/dev/null; then
        skip "none running, and dockerd cannot be started: not root or not installed"
    fi
    say "starting dockerd (log: $work/dockerd.log)"
    dockerd >"$work/dockerd.log" 2>&1 &
    started_dockerd=$!
    for ((i = 0; i < 120; i++)); do
        docker info >/dev/null 2>&1 && break
        kill -0 "$started_dockerd" 2>/dev/null || break
        sleep 0.5
    done
    if ! docker info >/dev/null 2>&1; then
        tail -n 5 "$work/dockerd.log" >&2
        kill "$started_dockerd" 2>/dev/null || true
        started_dockerd=""
        skip "dockerd did not start; its last log lines are above"
    fi
fi
say "Docker engine $(docker version -f '{{.Server.Version}}' 2>/dev/null)"

# --- 2. Base image ------------------------------------------------------------------------------
t0=$SECONDS
timeout "$(left)" bash "$root/deploy/docker-base.sh" || fail "no debian:12 base image"
say "debian:12 base ready ($((SECONDS - t0)) s)"

# --- 3. Image -----------------------------------------------------------------------------------
t0=$SECONDS
if [[ -n $programs ]]; then
    say "image from the programs in $programs on the Dockerfile's runtime-base stage"
    timeout "$(left)" docker build -q -f "$root/deploy/Dockerfile" --target runtime-base -t "$base_image" "$root" \
        >"$work/build.log" 2>&1 || { tail -n 30 "$work/build.log" >&2; fail "docker build --target runtime-base"; }
    mkdir -p "$work/ctx"
    bash "$root/deploy/collect-programs.sh" "$programs" "$work/ctx/bin" >/dev/null
    # The same two steps as the Dockerfile's `runtime` stage, with these programs.
    cat >"$work/ctx/Dockerfile" <<EOF
FROM $base_image
COPY bin/ /usr/local/bin/
RUN for p in rtpm-server rtpm-client rtpm-render rtpm-compare; do "\$p" --help >/dev/null || exit 1; done
EOF
    timeout "$(left)" docker build -q -t "$image" "$work/ctx" >>"$work/build.log" 2>&1 ||
        { tail -n 30 "$work/build.log" >&2; fail "docker build of the runtime image"; }
else
    say "image: docker build -f deploy/Dockerfile (all stages; compiles unless cached)"
    timeout "$(left)" docker build -f "$root/deploy/Dockerfile" -t "$image" "$root" >"$work/build.log" 2>&1 ||
        { tail -n 40 "$work/build.log" >&2; fail "docker build"; }
fi
size=$(docker image inspect -f '{{.Size}}' "$image")
say "image built in $((SECONDS - t0)) s: $((size / 1000000)) MB"
user=$(docker image inspect -f '{{.Config.User}}' "$image")
[[ -n $user && $user != root && $user != 0 ]] || fail "the image runs as root (User='$user')"
[[ -n $(docker image inspect -f '{{if .Config.Healthcheck}}{{.Config.Healthcheck.Test}}{{end}}' "$image") ]] ||
    fail "the image has no HEALTHCHECK"
if docker run --rm --entrypoint sh "$image" -c 'command -v c++ || command -v cmake || ls /usr/include/embree3' \
    >/dev/null 2>&1; then
    fail "the runtime image holds build tools or headers"
fi

# --- the settings both runs and the reference share ------------------------------------------------
export RTPM_TOKEN
RTPM_TOKEN=$(od -An -tx1 -N16 /dev/urandom | tr -d ' \n')
export RTPM_IMAGE=$image RTPM_CLIENTS=$clients RTPM_FRAMES=$frames RTPM_SCENE=RING RTPM_WIDTH=160 \
    RTPM_HEIGHT=120 RTPM_M=3 RTPM_OUT=cluster.exr
# Exact pixels on the wire; a deadline no loaded machine reaches (a late frame would be shown with
# older values, and the image would rightly differ from rtpm-render's); one batch per pass (pass
# sizes grown from frame times would differ between the two processes); figures per frame.
export RTPM_SERVER_ARGS="--encoding=float32 --deadline-ms=600000 --frame-budget-ms=0 --csv=/out/frames.csv"
render_args=(--scene RING --width 160 --height 120 --interleave 3 --frames "$frames" --frame-budget-ms 0)

# The reference: rtpm-render in the same image, same settings.
t0=$SECONDS
timeout "$(left)" docker run --name "$project-render" "$image" render "${render_args[@]}" --out /out/ref.exr \
    >"$work/render.log" 2>&1 || { tail -n 20 "$work/render.log" >&2; fail "rtpm-render in the image"; }
docker cp "$project-render:/out/ref.exr" "$work/ref.exr" >/dev/null
docker rm "$project-render" >/dev/null
say "reference rendered in the image ($((SECONDS - t0)) s)"

# checkRun DIR LABEL: DIR holds cluster.exr and frames.csv copied out of the server's container.
checkRun() {
    local dir=$1 label=$2
    [[ -s $dir/frames.csv && -s $dir/cluster.exr ]] || fail "$label: no image or CSV written"
    # CSV: frame,fps,photons_per_set,mode,bytes,slowest_client,slowest_ms,sets_arrived,sets,deadline,…
    local rows incomplete
    rows=$(awk -F, 'NR > 1' "$dir/frames.csv" | wc -l)
    incomplete=$(awk -F, 'NR > 1 && ($8 != $9 || $10 != 0)' "$dir/frames.csv" | wc -l)
    ((rows == frames)) || fail "$label: $rows frames in the CSV, expected $frames"
    ((incomplete == 0)) || fail "$label: $incomplete of $rows frames incomplete or shown at their deadline"
    awk -F, 'NR > 1 && $3 <= 0 { bad = 1 } END { exit bad }' "$dir/frames.csv" ||
        fail "$label: a frame has no photons (the comparison would prove little)"
    # Bit-identical pixels: same channels, same float32 values (the headers differ: each names the
    # program that wrote it). rtpm-compare runs in the image, on the two files mounted read-only.
    local verdict
    verdict=$(timeout "$(left)" docker run --rm -v "$dir/cluster.exr:/in/cluster.exr:ro" \
        -v "$work/ref.exr:/in/ref.exr:ro" "$image" compare --identical /in/cluster.exr /in/ref.exr 2>&1) ||
        fail "$label: the cluster's pixels differ from rtpm-render's: $(echo "$verdict" | grep rtpm-compare)"
    say "$label: $rows frames, all complete, pixels bit-identical to rtpm-render's"
}

# --- 4. Compose on one host ---------------------------------------------------------------------
if docker compose version >/dev/null 2>&1; then
    compose=(docker compose)
else
    command -v docker-compose >/dev/null || fail "neither 'docker compose' nor 'docker-compose' is installed"
    compose=(docker-compose)
fi
say "$("${compose[@]}" version 2>/dev/null | head -n 1)"
compose+=(-p "$project" -f "$root/deploy/docker-compose.yml")

# freePorts: sets RTPM_PORT and RTPM_HTTP_PORT to two free ports (no socket of any state uses them),
# so parallel runs and other services never collide. They are taken below the kernel's ephemeral
# range: a port inside it can be the local end of any outgoing connection (the daemon's, apt's),
# and Docker's proxy then fails to bind it ("address already in use") although nothing listens
# there. No traffic is sent to them.
freePorts() {
    local p i lo hi span base
    read -r lo hi </proc/sys/net/ipv4/ip_local_port_range 2>/dev/null || { lo=32768; hi=60999; }
    if ((lo > 12000)); then span=$((lo - 10002)); base=10000; else span=$((65000 - hi)); base=$((hi + 1)); fi
    ((span > 100)) || { base=10000; span=20000; }
    for ((i = 0; i < 50; i++)); do
        p=$((base + RANDOM % span))
        ss -Htan "( sport = :$p or sport = :$((p + 1)) )" | grep -q . || break
    done
    export RTPM_PORT=$p RTPM_HTTP_PORT=$((p + 1))
}
freePorts
t0=$SECONDS
timeout "$(left)" "${compose[@]}" config -q || fail "compose rejects deploy/docker-compose.yml"
timeout "$(left)" "${compose[@]}" up -d --no-build server >"$work/up.log" 2>&1 ||
    { cat "$work/up.log" >&2; fail "compose up server"; }
server=$("${compose[@]}" ps -q server)
[[ -n $server ]] || fail "no server container"
# Docker's HEALTHCHECK (every 10 s): healthy once the server listens; it waits for its clients.
health=""
for ((i = 0; i < 90; i++)); do
    health=$(docker inspect -f '{{.State.Health.Status}}' "$server")
    [[ $health == healthy ]] && break
    [[ $(docker inspect -f '{{.State.Running}}' "$server") == true ]] || break
    sleep 0.5
done
[[ $health == healthy ]] || { docker logs "$server" 2>&1 | tail -n 20 >&2; fail "server container not healthy (status '$health')"; }
say "server container healthy ($((SECONDS - t0)) s)"
timeout "$(left)" "${compose[@]}" up -d --no-build --scale client="$clients" client >>"$work/up.log" 2>&1 ||
    { cat "$work/up.log" >&2; fail "compose up client"; }
code=$(timeout "$(left)" docker wait "$server") || fail "server did not finish in time"
if ((code != 0)); then
    "${compose[@]}" logs --no-color 2>&1 | tail -n 40 >&2
    fail "server exited with status $code"
fi
# The clients leave after the server's Bye with status 0.
for c in $("${compose[@]}" ps -q client); do
    cc=$(timeout 60 docker wait "$c") || fail "a client did not exit after the server's Bye"
    ((cc == 0)) || { docker logs "$c" 2>&1 | tail -n 10 >&2; fail "a client exited with status $cc"; }
done
nclients=$("${compose[@]}" ps -q client | wc -l)
((nclients == clients)) || fail "$nclients client containers, expected $clients"
mkdir -p "$work/compose"
docker cp "$server:/out/cluster.exr" "$work/compose/" && docker cp "$server:/out/frames.csv" "$work/compose/" ||
    fail "cannot copy the server's output"
checkRun "$work/compose" "compose ($((SECONDS - t0)) s)"
"${compose[@]}" down -v --remove-orphans >/dev/null 2>&1
compose=()

# --- 5. The same file as a Swarm stack ------------------------------------------------------------
if ((swarm)); then
    t0=$SECONDS
    if [[ $(docker info -f '{{.Swarm.LocalNodeState}}') != active ]]; then
        docker swarm init --advertise-addr 127.0.0.1 >"$work/swarm.log" 2>&1 ||
            { cat "$work/swarm.log" >&2; fail "docker swarm init"; }
        made_swarm=1
    fi
    freePorts
    timeout "$(left)" docker stack deploy -c "$root/deploy/docker-compose.yml" "$project" >"$work/stack.log" 2>&1 ||
        { cat "$work/stack.log" >&2; fail "docker stack deploy"; }
    # The server task ends with status 0 ("Complete") after its frames; it is not restarted.
    state=""
    while :; do
        state=$(docker service ps --no-trunc -f desired-state=shutdown -f desired-state=running \
            --format '{{.CurrentState}}|{{.Error}}' "${project}_server" 2>/dev/null | head -n 1)
        [[ $state == Complete* || $state == Failed* || $state == Rejected* ]] && break
        ((SECONDS < budget)) || fail "stack: the server task did not complete in time (state '$state')"
        sleep 1
    done
    [[ $state == Complete* ]] || { docker service logs "${project}_server" 2>&1 | tail -n 20 >&2; fail "stack: server task '$state'"; }
    sc=$(docker ps -aq --filter "label=com.docker.swarm.service.name=${project}_server" | head -n 1)
    [[ -n $sc ]] || fail "stack: no server container"
    tasks=$(docker service ps -q "${project}_client" | wc -l)
    ((tasks >= clients)) || fail "stack: $tasks client tasks, expected $clients"
    mkdir -p "$work/stack"
    docker cp "$sc:/out/cluster.exr" "$work/stack/" && docker cp "$sc:/out/frames.csv" "$work/stack/" ||
        fail "stack: cannot copy the server's output"
    checkRun "$work/stack" "swarm stack ($((SECONDS - t0)) s)"
fi
