#!/bin/bash
# label: unit
# DEM terrains and polygon areas (GDAL/OGR): a file GDAL cannot open (with GDAL's reason), a DEM
# without a CRS (saying how to give one), a region of interest outside the DEM, area files that
# are missing, have zero area, a boundary that crosses itself, only points or a thickness that
# is not a number: exit 2, one line naming the key and file, nothing
# written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
DEM="$SRC/data/dem/hef_srtm.tif"
dem_scene() { # FILE TERRAIN-EXTRA [AREAS]
    cat > "$1" <<YAML
world:
  terrain: {kind: dem, cell_m: 200, $2}
  ${3:-}
camera: {position: [-3000, -3000, 4000], target: [0, 0, 2500]}
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
}
printf 'not a raster' > junk.tif
dem_scene a.yaml "dem: junk.tif"
expect 2 "world.terrain.dem = '.*junk.tif': GDAL cannot open it as a raster: .*not recognized" -- render a.yaml
dem_scene b.yaml "dem: missing.tif"
expect 2 "world.terrain.dem = '.*missing.tif': GDAL cannot open it.*No such file" -- simulate b.yaml
printf 'ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 10\n1 2 3\n4 5 6\n7 8 9\n' > plain.asc
dem_scene c.yaml "dem: plain.asc"
expect 2 "plain.asc': the file has no coordinate reference system; name the one its coordinates are in with world.terrain.dem_crs \(e.g. EPSG:4326" -- render c.yaml
dem_scene d.yaml "dem: $DEM, roi: [11.0, 46.7, 11.1, 46.8]"
expect 2 "world.terrain.roi = \[11, 46.7, 11.1, 46.8\] lies outside the DEM .*covers \[10.6" -- render d.yaml
dem_scene e.yaml "dem: $DEM, roi: [10.9, 46.7, 11.0, 46.8]"
expect 2 "world.terrain.roi = .* reaches outside the DEM" -- simulate e.yaml
dem_scene f.yaml "dem: $DEM, crs: EPSG:4326"
expect 2 "world.terrain.crs = 'EPSG:4326' .* is not projected in metres" -- render f.yaml
dem_scene g.yaml "dem: $DEM, roi: [10.7, 46.7, 10.8]"
expect 2 "world.terrain.roi has 3 values" -- render g.yaml
# polygon areas
cat > zero.geojson <<'J'
{"type":"Feature","properties":{},"geometry":{"type":"Polygon","coordinates":[[[10.80,46.80],[10.81,46.80],[10.82,46.80],[10.80,46.80]]]}}
J
cat > points.geojson <<'J'
{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[10.80,46.80]}}
J
dem_scene h.yaml "dem: $DEM" "areas: [{name: release, file: zero.geojson}]"
expect 2 "world.areas\[0\].file = '.*zero.geojson': polygon feature 0 has zero area" -- render h.yaml
dem_scene i.yaml "dem: $DEM" "areas: [{name: release, file: points.geojson}]"
expect 2 "world.areas\[0\].file = '.*points.geojson': no polygon in 1 feature" -- render i.yaml
dem_scene j.yaml "dem: $DEM" "areas: [{name: release, file: nowhere.shp}]"
expect 2 "world.areas\[0\].file = '.*nowhere.shp': GDAL/OGR cannot open it" -- simulate j.yaml
cat > bowtie.geojson <<'J'
{"type":"Feature","properties":{"thickness":1.5},"geometry":{"type":"Polygon","coordinates":[[[10.80,46.80],[10.81,46.805],[10.81,46.80],[10.80,46.805],[10.80,46.80]]]}}
J
dem_scene l.yaml "dem: $DEM" "areas: [{name: release, file: bowtie.geojson}]"
expect 2 "world.areas\[0\].file = '.*bowtie.geojson': polygon feature 0 is not a valid polygon \(Self-intersection.*must not cross itself" -- render l.yaml
cat > text.geojson <<'J'
{"type":"Feature","properties":{"thickness":"1.5 m"},"geometry":{"type":"Polygon","coordinates":[[[10.80,46.80],[10.81,46.80],[10.81,46.81],[10.80,46.81],[10.80,46.80]]]}}
J
dem_scene m.yaml "dem: $DEM" "areas: [{name: release, file: text.geojson}]"
expect 2 "world.areas\[0\].file = '.*text.geojson': feature 0's thickness = '1.5 m' is not a number" -- simulate m.yaml
# the release code's own rule: a polygon holding no snow (thickness 0 m) is refused
if has_feature avalanche; then
    sed 's/"thickness": *[0-9.]*/"thickness": 0/' "$SRC/data/avalanche/hef_release.geojson" > zerothick.geojson
    "$SQ" scene show alpine-avalanche |
        sed "s#data/dem/hef_srtm.tif#$DEM#; s#data/avalanche/hef_release.geojson#zerothick.geojson#" > n.yaml
    expect 2 "layers.slide.release.area = 'release' .*polygon 0 has thickness 0 m; a release thickness must be > 0 m" -- simulate n.yaml --set layers.slide.particles.spacing_m=3
    # a void (no-data) in the DEM under the release polygon: the DEM cropped to the preset's
    # region with the polygon burnt in as no-data (gdal-bin, installed by scripts/install-deps.sh)
    gdal_translate -q -projwin 10.86 46.84 10.93 46.785 -a_nodata -32768 -ot Int16 "$DEM" void.tif
    gdal_rasterize -q -burn -32768 -l hef_release "$SRC/data/avalanche/hef_release.geojson" void.tif
    "$SQ" scene show alpine-avalanche |
        sed "s#data/dem/hef_srtm.tif#void.tif#; s#data/avalanche/hef_release.geojson#$SRC/data/avalanche/hef_release.geojson#" > o.yaml
    expect 2 "layers.slide.release.area = 'release': 5[0-9.]* % of the release lies where the DEM has no data .*a release needs measured terrain" -- render o.yaml --set layers.slide.particles.spacing_m=3
fi
cat > k.yaml <<YAML
world:
  terrain: {kind: hills}
  areas: [{name: release, file: points.geojson}]
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
expect 2 "world.areas need a georeferenced terrain" -- render k.yaml
finish
