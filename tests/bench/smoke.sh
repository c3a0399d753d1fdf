#!/usr/bin/env bash
# One benchmark program or script of tests/bench (and deploy/scale-bench.sh) run once at its
# smallest size, as the ctest label bench-smoke does (tests/bench/CMakeLists.txt): it fails when
# the benchmark no longer runs or prints no result. The figures of such a run mean nothing.
# Everything is written into a temporary folder, removed at the end.
#
#   tests/bench/smoke.sh CASE BUILD_DIR
#
# CASE: viewer_encode ring_mirror viewer_cost cluster_convergence pov_compare cluster_bench
#       frame_profile sweep tls_cost viewer_port_probe scale_bench balance modes gltf_corpus. Exit status 77: skipped (the reason is printed).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
case=${1:?usage: smoke.sh CASE BUILD_DIR}
build=$(cd "${2:?usage: smoke.sh CASE BUILD_DIR}" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-bench-smoke.XXXXXX")
trap 'rm -rf "$work"' EXIT
export TMPDIR=$work RTPM_BUILD_DIR=$build RTPM_BENCH_SMOKE=1
bench=$build/tests/bench
render=$build/common/cmd/rtpm-render

# expectRows COUNT REGEX FILE: FILE has exactly COUNT lines matching REGEX (a result row each).
expectRows() {
    local n
    n=$(grep -cE "$2" "$3" || true)
    ((n == $1)) || { echo "smoke: expected $1 result rows matching '$2' in $(basename "$3"), found $n" >&2; exit 1; }
}
# run LOG CMD...: runs CMD with its output in LOG and on the terminal.
run() {
    local log=$1
    shift
    echo "+ $*"
    "$@" 2>&1 | tee "$log"
}
num='[0-9]+(\.[0-9]+)?'

case $case in
gltf_corpus)
    # The built-in scenes exported as .glb files, surveyed at 64x48: each renders, none dark.
    mkdir -p "$work/corpus"
    for scene in RING GLASS EGG HEADLIGHT CORNELL; do
        "$render" --scene "$scene" --export-glb "$work/corpus/$scene.glb" >/dev/null
    done
    run "$work/out.log" /usr/bin/python3 "$root/tests/bench/gltf_corpus.py" "$work/corpus" --build "$build" --size 64x48
    expectRows 5 "^\| [A-Z]+\.glb \| 0 \| $num \| " "$work/out.log"
    expectRows 1 "^renders 5 of 5 without flags, 0 of them dark" "$work/out.log"
    ;;
modes)
    # RING at 64x48, 4 frames, in the five modes.
    run "$work/out.log" bash "$root/tests/bench/modes_bench.sh"
    expectRows 1 "^\| RING \| $num \| $num \| $num \| $num \| $num \| $num after $num s, (1/)?[0-9]+ \|$" "$work/out.log"
    ;;
balance)
    # Both clients alone, round-robin and balanced, in the light-edit mode at 64x48.
    run "$work/out.log" bash "$root/tests/bench/balance_bench.sh"
    expectRows 1 "^\| light \| $num \| $num \| $num \| $num \| $num \| $num \| $num \| $num \| [0-9]+ \| " "$work/out.log"
    ;;
viewer_encode)
    "$render" --scene RING --width 64 --height 48 --frames 1 --out "$work/ring.exr" >/dev/null
    RTPM_VIEWER_BENCH_EXR=$work/ring.exr "$bench/viewer_encode_bench"
    ;;
ring_mirror)
    b=$bench/ring_mirror_bench
    for estimator in progressive knn; do
        run "$work/$estimator.log" "$b" --estimator "$estimator" --frames 3 --width 32 --height 24 --photons 2000 \
            --csv "$work/$estimator.csv" --out "$work/$estimator.exr"
        expectRows 3 "^$estimator,2000,[1-3],$num,$num,$num,$num,$num$" "$work/$estimator.csv"
        [[ -s $work/$estimator.png ]] || { echo "smoke: no $estimator.png" >&2; exit 1; }
    done
    run "$work/budget.log" "$b" --frames 2 --width 32 --height 24 --photons 2000 --frame-budget-ms 50 --seconds 5
    run "$work/ref.log" "$b" --reference "$work/ref.exr" --width 32 --height 24
    # The reference against itself: no error, all of its energy.
    run "$work/self.log" "$b" --compare "$work/ref.exr"
    expectRows 1 '^rel_mae 0\.00000 energy 1\.00000$' "$work/self.log"
    run "$work/cmp.log" "$b" --compare "$work/progressive.exr" --minus "$work/ref.exr" --out "$work/diff.exr"
    expectRows 1 "^rel_mae $num energy -?$num$" "$work/cmp.log"
    run "$work/map.log" "$b" --compare "$work/progressive.exr" --error-map "$work/map.png"
    expectRows 6 "^the worst +[0-9]+ % of [0-9]+ pixels: $num of the absolute error$" "$work/map.log"
    [[ -s $work/map.png ]] || { echo "smoke: no error map" >&2; exit 1; }
    run "$work/scene.log" "$b" --write-scene "$work/mirror.glb"
    "$render" --scene "$work/mirror.glb" --photon-depth 2 --diffuse-bounces 0 --width 32 --height 24 --frames 1 \
        --out "$work/mirror.exr" >/dev/null
    run "$work/static.log" "$b" --static-frame 1000 --static-frame 3000 --photons 1000 --frames 2
    expectRows 2 "^stored +[0-9]+ .*still frame median +$num ms" "$work/static.log"
    ;;
viewer_cost)
    # viewer_feed replays a frame into a real master, without and with a headless-Chromium page.
    run "$work/out.log" env VIEWER_COST_CACHE="$work" bash "$root/tests/bench/viewer_cost.sh" 4 64 48 0
    expectRows 1 "^viewer CPU $num s = " "$work/out.log"
    expectRows 2 '^summary:' "$work/out.log"
    ;;
cluster_convergence)
    # With POV-Ray beside it, taking turns (its row, the clusters' rows, the ratio lines), on a
    # variant of the scene (pov_compare below renders the default one).
    run "$work/out.log" bash "$root/tests/bench/cluster_convergence.sh" --build "$build" --frames "1 2" --size 64x48 --repeat 3 \
        --pov 20000:20:100 --light -0.3,0.7,0.35 --ring-height 0.5
    expectRows 4 "^\| (progressive|knn) \| [12] \| $num \| $num \| $num \| $num \|$" "$work/out.log"
    expectRows 1 "^\| POV-Ray gather 20,100 \| 20000 photons \| $num \| $num \| $num \| $num \|$" "$work/out.log"
    expectRows 4 "^(progressive|knn): first run at rel. MAE <= 0.0[25]: " "$work/out.log"
    ;;
pov_compare)
    run "$work/out.log" /usr/bin/python3 "$root/tests/bench/pov_compare.py" --build "$build" --pov-photons 20000 \
        --pov-gather 20:100 --seconds 1 --width 64 --height 48 --out "$work/out"
    expectRows 1 "^\"POV-Ray gather 20,100\",20000 photons,$num,$num,$num,-?$num" "$work/out/pov_compare.csv"
    expectRows 2 "^rtpm (progressive|knn) M=3 P=20000 budget 16.7 ms,1 frames," "$work/out/pov_compare.csv"
    [[ -s $work/out/pov_compare.png ]] || { echo "smoke: no pov_compare.png" >&2; exit 1; }
    ;;
cluster_bench)
    # Every table once: references (--refs), fps vs clients, vs resolution, memory over a run.
    export REFS=$work/refs
    run "$work/out.log" bash "$root/tests/bench/cluster_bench.sh" --refs --all --scenes "MIRROR RING" \
        --clients 1 --scaling-size 32x24 --sizes 32x24 --res-clients 1 --res-modes walkthrough \
        --frames 3 --walk-frames 3 --walk-photons 2000 --ref-photons 2000 --ref-k 20 \
        --mem-frames 100 --mem-every 20 --mem-sample 10 --mem-clients 1 --mem-photons 500 --mem-size 32x24
    expectRows 4 "^\| (MIRROR|RING) \| progressive \| (interaction|walkthrough) \| 1 \| $num \|" "$work/out.log"
    expectRows 2 "^\| (MIRROR|RING) \| progressive \| walkthrough \| 32x24 \| $num \|" "$work/out.log"
    expectRows 1 "^\| server \| $num \| $num \|" "$work/out.log"
    [[ -s $REFS/RING_32x24_knn.exr ]] || { echo "smoke: --refs made no reference" >&2; exit 1; }
    ;;
frame_profile)
    status=0
    bash "$root/tests/bench/frame_profile.sh" --frames 1 --size 32x24 RING >"$work/out.log" || status=$?
    cat "$work/out.log"
    ((status == 0)) || exit "$status"
    expectRows 1 "^\| RING \| interaction \| knn \| 1 \| [0-9]+ % \|" "$work/out.log"
    ;;
sweep)
    # Two points: rtpm's defaults and the paper's base point (N = 8 000 stored photons per set,
    # whatever the size: the others of --quick cost seconds each).
    run "$work/out.log" bash "$root/tests/bench/sweep.sh" --make-references --run --quick --groups default,base \
        --scenes RING --size 32x24 --ref-photons 20000 --out "$work/out" --cache "$work/cache"
    expectRows 2 '^RING,(default|base),' "$work/out/sweep_results.csv"
    [[ -s $work/out/SWEEP.md && -s $work/out/sweep_ring.png ]] || { echo "smoke: no SWEEP.md or PNG" >&2; exit 1; }
    ;;
tls_cost)
    run "$work/out.log" bash "$root/tests/bench/tls_cost.sh" --size 64x48 --frames 3 "$build" 1
    expectRows 2 "^\| (plain|TLS) \| $num \| $num \| $num \|" "$work/out.log"
    ;;
viewer_port_probe)
    # The probes of fixed length up to 5 s; fds (1 000 connections, 7 s of closing, about 35 s under
    # load) and nat (a 20 s run) are left out for their cost.
    run "$work/out.log" /usr/bin/python3 "$root/tests/bench/viewer_port_probe.py" "$build" insecure rebinding nodes \
        origin guesses tokenless
    expectRows 4 '^insecure: --http ' "$work/out.log"
    expectRows 5 '^(rebinding|nodes|origin|guesses|tokenless): ' "$work/out.log"
    ;;
scale_bench)
    # Root only (network namespaces, cgroups), like the multihost test.
    if ! reason=$(source "$root/deploy/netns.sh" && netnsCheck); then
        echo "smoke: scale-bench skipped: $reason"
        exit 77
    fi
    run "$work/out.log" bash "$root/deploy/scale-bench.sh" --clients 1 --size 32x24 -M 1 --frames 3 --walk-frames 3 \
        --walk-photons 2000 --client-cores 1 --master-cores 1 --ref-photons 2000 --refs "$work/refs" --out "$work/out"
    # interaction and walkthrough at the size, walkthrough at twice the size.
    expectRows 3 '^RING,(interaction|walkthrough),1,' "$work/out/scale.csv"
    [[ -s $work/out/scale.md && -s $work/out/scale.png ]] || { echo "smoke: no scale.md or scale.png" >&2; exit 1; }
    ;;
*)
    echo "smoke.sh: unknown case '$case'" >&2
    exit 2
    ;;
esac
echo "smoke: $case ran"
