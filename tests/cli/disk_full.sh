#!/bin/bash
# label: unit
# A full disk is a runtime error (exit 1) that says "no space left on device" for every output
# format (MP4, PNG frames, NetCDF, VTK, metrics CSV), and leaves nothing behind: no final name,
# no temporary. The outputs go to a tmpfs filled to the last block, mounted in a private mount
# namespace (unshare -m) so nothing outlives the test; without the right to mount (not root,
# no user namespaces) the test says so and passes without checking.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
if ! unshare -m true 2>/dev/null; then
    echo "skipped: cannot create a mount namespace for a small tmpfs (needs root)"
    finish
    exit 0
fi
tiny_scene s.yaml
mkdir full
# run NAME EXTRA-ARGS...: squall with its outputs on a full 1 MiB tmpfs at ./full
run() {
    local name="$1"
    shift
    unshare -m bash -c '
        mount -t tmpfs -o size=1m tmpfs full || exit 99
        dd if=/dev/zero of=full/filler bs=4k 2>/dev/null
        "$@" > out.txt 2> err.txt
        echo $? > rc.txt
        ls -A full | grep -v "^filler$" > left.txt
        umount full' _ "$SQ" "$@"
    local rc
    rc=$(cat rc.txt)
    [ "$rc" = 1 ] || fail "$name: exit $rc, expected 1 (stderr: $(cat err.txt))"
    grep -q "no space left on device" err.txt || fail "$name: stderr does not say 'no space left on device': $(cat err.txt)"
    [ "$(grep -c . err.txt)" = 1 ] || fail "$name: stderr is not one line: $(cat err.txt)"
    [ -s left.txt ] && fail "$name: files left on the full disk: $(cat left.txt)"
    rm -f out.txt err.txt rc.txt left.txt
}
# (frames need the renderer: not in a -DSQ_WITH_GL=OFF build)
if has_feature gl && has_feature mp4; then run mp4 render s.yaml -o full/v.mp4; fi
if has_feature gl; then run png render s.yaml -o full/frames; fi
run netcdf simulate desert-sandstorm --frames 1 --fields full/f --set layers.storm.domain.nx=16 \
    --set layers.storm.domain.ny=16 --set layers.storm.domain.nz=8
run vtk simulate desert-sandstorm --frames 1 --fields full/f --set output.fields_format=vtk \
    --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=16 --set layers.storm.domain.nz=8
run csv simulate s.yaml --frames 200 --metrics full/m.csv
finish
