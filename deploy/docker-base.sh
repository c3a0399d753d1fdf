#!/usr/bin/env bash
# Makes the `debian:12` base image locally when no image registry can be reached: debootstrap
# (minbase) of bookworm from the Debian archive this machine's apt sources name, then
# `docker import`. Does nothing when `debian:12` is already present (pulled or made before).
#
#   deploy/docker-base.sh [MIRROR_URL]       (root; needs debootstrap and a running dockerd)
#
# The image holds what the official debian:12 image holds: a minbase bookworm with apt sources for
# bookworm, bookworm-updates and bookworm-security, no package lists or .deb cache, and the same
# default command (bash). About 120 MB; it takes a minute or two (network bound).
set -euo pipefail

tag=${RTPM_BASE_IMAGE:-debian:12}
if docker image inspect "$tag" >/dev/null 2>&1; then
    echo "docker-base: $tag present"
    exit 0
fi
if ! command -v debootstrap >/dev/null; then
    echo "docker-base: $tag is missing and debootstrap is not installed (deploy/install-docker-deps.sh)" >&2
    exit 1
fi

# The archive apt already uses for SUITE: a one-line `deb URL SUITE …` entry, or a deb822 stanza
# whose Suites list holds SUITE itself.
sourceUri() {
    local f suite=$1
    for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
        [[ -f $f ]] || continue
        awk -v suite="$suite" '$1 == "deb" { i = 2; if ($2 ~ /^\[/) { while ($i !~ /\]$/) i++; i++ }
                           if ($(i + 1) == suite) { print $i; exit } }' "$f"
    done
    for f in /etc/apt/sources.list.d/*.sources; do
        [[ -f $f ]] || continue
        awk -v suite="$suite" 'BEGIN { RS = ""; FS = "\n" }
             { uri = ""; ok = 0
               for (i = 1; i <= NF; i++) {
                   if ($i ~ /^URIs:/) { split($i, a, /[ \t]+/); uri = a[2] }
                   if ($i ~ /^Suites:/) { n = split($i, s, /[ \t]+/); for (j = 2; j <= n; j++) if (s[j] == suite) ok = 1 }
               }
               if (ok && uri != "") { print uri; exit } }' "$f"
    done
}
mirror=${1:-$(sourceUri bookworm | head -n 1)}
mirror=${mirror:-http://deb.debian.org/debian}
mirror=${mirror%/}

root=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-debian12.XXXXXX")
trap 'rm -rf "$root"' EXIT
echo "docker-base: debootstrap --variant=minbase bookworm from $mirror"
if ! debootstrap --variant=minbase bookworm "$root" "$mirror" >"$root.log" 2>&1; then
    tail -n 20 "$root.log" >&2
    rm -f "$root.log"
    echo "docker-base: debootstrap failed" >&2
    exit 1
fi
rm -f "$root.log"

security=$(sourceUri bookworm-security | head -n 1)
security=${security:-http://deb.debian.org/debian-security}
cat >"$root/etc/apt/sources.list" <<EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb $security bookworm-security main
EOF
# As the official image: no downloaded packages or lists (apt-get update first), no apt cache.
rm -rf "$root"/var/cache/apt/archives/*.deb "$root"/var/cache/apt/*.bin "$root"/var/lib/apt/lists/* \
    "$root"/var/log/*.log "$root"/tmp/* "$root"/root/.bash_history
echo "docker-base: importing as $tag"
tar --numeric-owner -C "$root" -c . |
    docker import --change 'CMD ["bash"]' --change 'ENV LANG=C.UTF-8' - "$tag" >/dev/null
docker image ls "$tag"
