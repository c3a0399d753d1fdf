# Sourced by the deploy scripts and the cluster benchmarks: where a build tree keeps each program,
# and how many render threads a client started beside others on one machine gets, in one place.
# rtpm-render and rtpm-compare sit in common/cmd/ once common/ is split into stage folders, in
# common/ before; rtpm-server and rtpm-client in server/ and client/.

# rtpmProgram BUILD_DIR NAME: prints the path of the built program NAME (rtpm-server, rtpm-client,
# rtpm-render, rtpm-compare), or fails with a message naming the places it looked.
rtpmProgram() {
    local build=$1 name=$2 rel
    for rel in server/$name client/$name common/cmd/$name common/$name; do
        if [[ -x $build/$rel && -f $build/$rel ]]; then
            echo "$build/$rel"
            return 0
        fi
    done
    echo "rtpm: $name is not built in $build (looked in server/, client/, common/cmd/, common/)" >&2
    return 1
}

# rtpmClientThreads CLIENTS: render threads for each of CLIENTS clients sharing this machine: twice
# its share of the cores, at least 1 and at most all of them (2 clients on 2 cores: 2 each). Sets
# rarely split evenly (9 sets: 5 and 4), and the client with fewer is done first; with one thread
# each its core then idled while the other finished, with two the busier client takes it (RING's
# accumulating orbit at 640×480: 10.0–10.1 fps → 10.7–10.9, light edits 12.4–12.6 → 14.2–14.7;
# tests/bench/RESULTS.md). More than twice would only add threads that wait for a core.
rtpmClientThreads() {
    local clients=$1 cores
    [[ $clients =~ ^[0-9]+$ ]] && ((clients >= 1)) || clients=1
    cores=$(nproc 2>/dev/null || echo 1)
    local t=$((2 * cores / clients))
    ((t > cores)) && t=$cores
    ((t < 1)) && t=1
    echo "$t"
}
