#!/usr/bin/env bash
# deploy/paths.sh rtpmClientThreads: the render threads each of N clients sharing a machine gets
# (twice its share of the cores, at least 1, at most all; a count that is not a positive number
# counts as one client), on machines of 1, 2 and 8 cores (a stand-in `nproc` first on PATH).
# Usage: client_threads_test.sh REPO
set -euo pipefail
repo=${1:?usage: client_threads_test.sh REPO}
fake=$(mktemp -d "${TMPDIR:-/tmp}/rtpm-threads.XXXXXX")
trap 'rm -rf "$fake"' EXIT
printf '#!/bin/sh\necho "$RTPM_TEST_CORES"\n' >"$fake/nproc"
chmod +x "$fake/nproc"
PATH="$fake:$PATH"
source "$repo/deploy/paths.sh"
failed=0
# cores clients expected
while read -r cores clients expected; do
    got=$(RTPM_TEST_CORES=$cores rtpmClientThreads "$clients")
    if [[ $got != "$expected" ]]; then
        echo "FAIL: $clients clients on $cores cores: $got threads each, expected $expected" >&2
        failed=1
    fi
done <<'TABLE'
1 1 1
1 2 1
2 1 2
2 2 2
2 3 1
2 4 1
2 16 1
8 1 8
8 2 8
8 3 5
8 4 4
8 16 1
8 0 8
8 x 8
TABLE
((failed == 0)) && echo "rtpmClientThreads: all 14 cases as expected"
exit "$failed"
