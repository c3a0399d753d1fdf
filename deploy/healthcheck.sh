#!/bin/sh
# Docker HEALTHCHECK of the rtpm image, by which rtpm program the container runs: rtpm-server is
# healthy once it listens (a TCP socket in LISTEN state in the container's network namespace),
# rtpm-client once it is connected to its master (an ESTABLISHED socket; while it still retries,
# it is not). rtpm-render, or no rtpm program (a shell), is healthy while it runs. Reads /proc
# only: no connection the master would have to log.
set -eu
program=""
for comm in /proc/[0-9]*/comm; do
    case "$(cat "$comm" 2>/dev/null)" in
        rtpm-server) program=server; break ;;
        rtpm-client) program=client; break ;;
    esac
done
# tcpState HEX: a TCP socket (IPv4 or IPv6) is in that state (0A LISTEN, 01 ESTABLISHED).
tcpState() {
    for table in /proc/net/tcp /proc/net/tcp6; do
        [ -r "$table" ] && awk -v st="$1" 'NR > 1 && $4 == st { found = 1 } END { exit !found }' "$table" && return 0
    done
    return 1
}
case $program in
    server) tcpState 0A || { echo "rtpm-server is not listening"; exit 1; } ;;
    client) tcpState 01 || { echo "rtpm-client is not connected to its master"; exit 1; } ;;
esac
exit 0
