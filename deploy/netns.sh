# Sourced by tests/multihost/multihost_test.sh and deploy/scale-bench.sh: emulated hosts on one
# machine (root). Each host is a network namespace joined to a switch — a bridge inside a namespace
# of its own — by a veth pair whose two ends are shaped with `tc qdisc … tbf` to the host's link
# rate in both directions. A host may also get a CPU limit: a cgroup v1 `cpu` group with
# cpu.cfs_quota_us, and a `cpuacct` group that counts its CPU time. Every address lives inside
# the namespaces made here (10.213.0.0/16); nothing touches the host's own interfaces.
#
#   netnsCheck                      fails with a reason when namespaces/veth/tbf cannot be used
#   netnsInit PREFIX                the switch: namespace PREFIX-sw with bridge br0
#   netnsHost NAME ADDR RATE        namespace PREFIX-NAME with eth0 = ADDR/16, RATE each way
#                                   (a tc rate: 100mbit, 1gbit, …)
#   netnsName NAME                  the namespace of host NAME, for `ip netns exec` (which execs
#                                   CMD in place, so `$!` of a background one is CMD's PID)
#   netnsTxBytes NAME               bytes host NAME sent through its shaped eth0 (tbf counter)
#   cpuGroup NAME QUOTA             cgroups PREFIX-NAME (cpu + cpuacct); QUOTA in cores (0 = none)
#   cpuGroupRun NAME CMD…           joins the cgroups of NAME and becomes CMD (an executable, not
#                                   a function): call it in the background, `cpuGroupRun … &`
#   cpuGroupSeconds NAME…           CPU seconds used so far by everything that ran in the groups
#                                   NAME… (summed; one read of all counters)
#   netnsTeardown                   deletes every namespace and cgroup made (idempotent)

netnsPrefix=""
netnsMade=()
cpuGroupsMade=()
cgCpu=/sys/fs/cgroup/cpu
cgAcct=/sys/fs/cgroup/cpuacct

netnsCheck() {
    [[ $(id -u) -eq 0 ]] || { echo "needs root (network namespaces, veth, tc)"; return 1; }
    command -v ip >/dev/null && command -v tc >/dev/null || { echo "needs iproute2 (ip, tc)"; return 1; }
    local probe=rtpmprobe$$
    ip netns add "$probe" 2>/dev/null || { echo "cannot create a network namespace"; return 1; }
    if ! ip -n "$probe" link add vpa type veth peer name vpb 2>/dev/null ||
        ! ip -n "$probe" link add vbr type bridge 2>/dev/null ||
        ! tc -n "$probe" qdisc add dev vpa root tbf rate 1gbit burst 256kb latency 50ms 2>/dev/null; then
        ip netns del "$probe"
        echo "cannot create veth pairs, bridges or tbf qdiscs in a namespace"
        return 1
    fi
    ip netns del "$probe"
}

# tbfArgs RATE: a token bucket that holds 10 ms of RATE (at least 64 kB: one GSO segment), so the
# rate holds at any timer frequency; packets wait up to 100 ms before being dropped.
tbfArgs() {
    local bits
    bits=$(awk -v r="$1" 'BEGIN { n = r + 0; u = tolower(r); sub(/^[0-9.]+/, "", u)
        m = u == "kbit" ? 1e3 : u == "mbit" ? 1e6 : u == "gbit" ? 1e9 : u == "bit" || u == "" ? 1 : 0
        printf "%.0f", n * m }')
    ((bits > 0)) || { echo "netns: bad rate '$1'" >&2; return 1; }
    local burst=$((bits / 8 / 100))
    ((burst < 65536)) && burst=65536
    echo "rate $1 burst $burst latency 100ms"
}

netnsInit() {
    netnsPrefix=$1
    ip netns add "$netnsPrefix-sw"
    netnsMade+=("$netnsPrefix-sw")
    ip -n "$netnsPrefix-sw" link set lo up
    ip -n "$netnsPrefix-sw" link add br0 type bridge
    ip -n "$netnsPrefix-sw" link set br0 up
}

netnsHost() {
    local name=$1 addr=$2 rate=$3 ns=$netnsPrefix-$1 tbf
    tbf=$(tbfArgs "$rate") || return 1
    ip netns add "$ns"
    netnsMade+=("$ns")
    ip -n "$ns" link set lo up
    # The pair is made in the host's namespace and its ends moved, so the names never clash with
    # another run's.
    ip -n "$ns" link add eth0 type veth peer name "p-$name" netns "$netnsPrefix-sw"
    ip -n "$ns" addr add "$addr/16" dev eth0
    ip -n "$ns" link set eth0 up
    ip -n "$netnsPrefix-sw" link set "p-$name" master br0
    ip -n "$netnsPrefix-sw" link set "p-$name" up
    # Host → switch on the host's eth0, switch → host on the switch port.
    # shellcheck disable=SC2086
    tc -n "$ns" qdisc add dev eth0 root tbf $tbf
    # shellcheck disable=SC2086
    tc -n "$netnsPrefix-sw" qdisc add dev "p-$name" root tbf $tbf
}

netnsName() { echo "$netnsPrefix-$1"; }

netnsTxBytes() {
    tc -s -n "$netnsPrefix-$1" qdisc show dev eth0 | awk '/^qdisc tbf/ { q = 1 } q && /Sent/ { print $2; exit }'
}

cpuGroup() {
    local name=$1 cores=$2 g=$netnsPrefix-$1
    [[ -d $cgCpu && -d $cgAcct ]] || { echo "netns: cgroup v1 cpu and cpuacct controllers not mounted" >&2; return 1; }
    mkdir -p "$cgCpu/$g" "$cgAcct/$g"
    cpuGroupsMade+=("$g")
    if [[ $cores != 0 ]]; then
        echo 100000 >"$cgCpu/$g/cpu.cfs_period_us"
        awk -v c="$cores" 'BEGIN { printf "%d\n", c * 100000 }' >"$cgCpu/$g/cpu.cfs_quota_us"
    fi
}

cpuGroupRun() {
    local g=$netnsPrefix-$1
    shift
    # The background shell joins the groups, then becomes CMD: CMD and its threads are counted and
    # limited, and `$!` is CMD's PID.
    echo "$BASHPID" >"$cgCpu/$g/cgroup.procs"
    echo "$BASHPID" >"$cgAcct/$g/cgroup.procs"
    exec "$@"
}

cpuGroupSeconds() {
    local g files=()
    for g in "$@"; do files+=("$cgAcct/$netnsPrefix-$g/cpuacct.usage"); done
    awk '{ s += $1 } END { printf "%.6f\n", s / 1e9 }' "${files[@]}"
}

netnsTeardown() {
    local ns g i
    for ns in "${netnsMade[@]}"; do ip netns del "$ns" 2>/dev/null || true; done
    netnsMade=()
    for g in "${cpuGroupsMade[@]}"; do
        # A group can be removed once its processes have exited (bounded wait).
        for ((i = 0; i < 50; i++)); do
            rmdir "$cgCpu/$g" "$cgAcct/$g" 2>/dev/null && break
            [[ -d $cgCpu/$g || -d $cgAcct/$g ]] || break
            sleep 0.1
        done
    done
    cpuGroupsMade=()
}
