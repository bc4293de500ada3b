#!/bin/bash
# label: unit
# A full disk is a runtime error (exit 1) that says "no space left on device" for every output
# format (MP4, PNG frames, NetCDF, VTK, metrics CSV, wrf export, hazard rasters), and leaves
# nothing behind: no final name, no temporary; also when the disk fills up while a file is being
# written (a few blocks left, so the temporary is created and part of the data fits: HDF5 under
# libnetcdf used to crash at exit after such a failed flush). The outputs go to a tmpfs filled to
# the last block, mounted in a private mount namespace (unshare -m) so nothing outlives the test;
# without the right to mount (not root, no user namespaces) the test says so and passes without
# checking.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
if ! unshare -m true 2>/dev/null; then
    echo "skipped: cannot create a mount namespace for a small tmpfs (needs root)"
    finish
    exit 0
fi
tiny_scene s.yaml
mkdir full
# run NAME EXTRA-ARGS...: squall with its outputs on a full 1 MiB tmpfs at ./full
# (FREE_KB=N: N KiB left free instead of none)
run() {
    local name="$1"
    shift
    FREE_KB="${FREE_KB:-0}" unshare -m bash -c '
        mount -t tmpfs -o size=1m tmpfs full || exit 99
        dd if=/dev/zero of=full/filler bs=4k count=$(((1024 - FREE_KB) / 4)) 2>/dev/null
        "$@" > out.txt 2> err.txt
        echo $? > rc.txt
        ls -A full | grep -v "^filler$" > left.txt
        umount full' _ "$SQ" "$@"
    local rc
    rc=$(cat rc.txt)
    [ "$rc" = 99 ] && fail "$name: cannot mount the tmpfs"
    [ "$rc" = 1 ] || fail "$name: exit $rc, expected 1 (stderr: $(cat err.txt))"
    grep -q "no space left on device" err.txt || fail "$name: stderr does not say 'no space left on device': $(cat err.txt)"
    grep -q "\.tmp-" err.txt && fail "$name: stderr names a temporary, not the output: $(cat err.txt)"
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
# the disk fills up during the write: 64 KiB free, fields of 32x32x16 cells (~1 MB per file);
# the error names the file asked for, not its temporary
for format in netcdf vtk; do
    FREE_KB=64 run "$format (filling up)" simulate desert-sandstorm --frames 1 --fields full/f \
        --set output.fields_format=$format --set layers.storm.domain.nx=32 \
        --set layers.storm.domain.ny=32 --set layers.storm.domain.nz=16
done
if has_feature mp4; then
    FREE_KB=64 run "mp4 (filling up)" render desert-sandstorm -o full/v.mp4 --size 640x360 \
        --duration 2 --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=16 \
        --set layers.storm.domain.nz=8
fi
WRF="$SRC/data/wrf/wrf_d01_allvars_cropped.nc"
if has_feature wrf && [ -f "$WRF" ]; then
    FREE_KB=64 run "wrf export (filling up)" wrf export "$WRF" --time 0 -o full/w.nc
fi
# hazard rasters (GDAL): GeoTIFF on a full disk, ESRI ASCII filling up (GDAL lost errno and the
# CLI said "TIFFWriteDirectoryTagData:IO error writing tag data", exit 2)
if has_feature gdal && has_feature avalanche; then
    run "rasters tif" simulate "$SRC/tests/cli/data/dem-avalanche.yaml" --rasters full/r \
        --threads 1
    FREE_KB=8 run "rasters asc (filling up)" simulate "$SRC/tests/cli/data/dem-avalanche.yaml" \
        --rasters full/r --raster-format asc --threads 1
fi
finish
