#!/usr/bin/env bash
# Copies rtpm-server, rtpm-client, rtpm-render and rtpm-compare from a build tree into DEST, stripped, and checks
# that every shared library they load resolves on this system.
#
#   deploy/collect-programs.sh BUILD_DIR DEST
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$here/paths.sh"
build=${1:?usage: collect-programs.sh BUILD_DIR DEST}
dest=${2:?usage: collect-programs.sh BUILD_DIR DEST}
mkdir -p "$dest"
for name in rtpm-server rtpm-client rtpm-render rtpm-compare; do
    src=$(rtpmProgram "$build" "$name")
    install -m 0755 "$src" "$dest/$name"
    strip --strip-unneeded "$dest/$name"
    if ldd "$dest/$name" | grep -q "not found"; then
        ldd "$dest/$name" | grep "not found" >&2
        echo "collect-programs: $name needs libraries that are not installed" >&2
        exit 1
    fi
done
ls -l "$dest"
