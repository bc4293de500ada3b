#!/bin/bash
# Hazard rasters never replace an input, and the refusal comes before the run (issue 16, bad
# input): a DEM that happens to be named like one of the maps (DIR/peak_speed.tif), or a release
# polygon named DIR/summary.json, given with --rasters DIR --overwrite, ends at once with exit 2
# and one line naming the output and the input; nothing in DIR changes (no map of the run is
# written beside it). The same with --raster-format asc for a DEM named peak_speed.prj's grid.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
mkdir d
cp "$SRC/data/dem/hef_srtm.tif" d/peak_speed.tif
cp "$SRC/data/avalanche/hef_release.geojson" d/rel.geojson
sed -e 's#dem: ../../../data/dem/hef_srtm.tif#dem: d/peak_speed.tif#' \
    -e 's#file: ../../../data/avalanche/hef_release.geojson#file: d/rel.geojson#' \
    "$SRC/tests/cli/data/dem-avalanche.yaml" > s.yaml
grep -q 'd/peak_speed.tif' s.yaml && grep -q 'd/rel.geojson' s.yaml || fail "scene not rewritten"
expect 2 "output 'd/+peak_speed.tif' is the DEM .*inputs are never written" -- \
    simulate s.yaml --rasters d --overwrite --threads 1
# the release polygon as the summary
cp "$SRC/data/dem/hef_srtm.tif" dem.tif
mv d/rel.geojson d/summary.json
sed -i -e 's#dem: d/peak_speed.tif#dem: dem.tif#' -e 's#file: d/rel.geojson#file: d/summary.json#' \
    s.yaml
expect 2 "output 'd/+summary.json' is the .*d/summary.json.*inputs are never written" -- \
    simulate s.yaml --rasters d --overwrite --threads 1
# ESRI ASCII: the .prj beside the grid is an output too
mv d/summary.json d/rel.geojson
cp "$SRC/data/dem/hef_srtm.tif" d/deposit_depth.prj
sed -i -e 's#file: d/summary.json#file: d/rel.geojson#' -e 's#dem: dem.tif#dem: d/deposit_depth.prj#' \
    s.yaml
expect 2 "output 'd/+deposit_depth.prj' is the DEM" -- \
    simulate s.yaml --rasters d --raster-format asc --overwrite --threads 1
finish
