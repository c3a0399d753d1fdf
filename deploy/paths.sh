# Sourced by the deploy scripts: where a build tree keeps each program, in one place.
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
