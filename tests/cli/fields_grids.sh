#!/bin/bash
# label: unit
# requires: netcdf snowdrift snowcover
# A file holds one grid: a scene whose layers publish 2D maps on different grids (the snowdrift's
# depth on its lattice, the snow cover's over the whole world) writes one map file per grid,
# PREFIX_maps_NNNNN and PREFIX_maps2_NNNNN in the order of the layers, each with its own .pvd
# time series; the grids' extents and the variables are the layers' own.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
cat > g.yaml <<'YAML'
world:
  terrain: {kind: flat, material: snow, size_m: [200, 200], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
layers:
  - type: snowdrift
    name: drift
    domain: {nx: 32, ny: 24, nz: 16, cell_size_m: 2}
    wind: {speed_mps: 6}
    snow: {snowfall_mmh: 4, speedup: 2000}
    draw: {flakes: 0}
  - type: snowcover
    name: cover
    snowfall: {rate_mmh: 4, speedup: 2000, cell_m: 4}
output: {fps: 4, frames: 2, fields_every: 1, fields_format: both}
YAML
"$SQ" simulate g.yaml --fields f --quiet 2> err.txt || fail "simulate exited $?: $(cat err.txt)"
for fr in 00000 00001; do
    for ext in vti nc; do
        [ -f "f_maps_$fr.$ext" ] || fail "f_maps_$fr.$ext missing: $(ls)"
        [ -f "f_maps2_$fr.$ext" ] || fail "f_maps2_$fr.$ext missing: $(ls)"
    done
done
[ -f f.pvd ] || fail "f.pvd (the drift's 3D fields) missing"
[ -f f_00000.vti ] || fail "f_00000.vti (the drift's 3D fields) missing"
for t in f_maps f_maps2; do
    [ -f $t.pvd ] || fail "$t.pvd missing"
    grep -q "${t}_00001.vti" $t.pvd 2>/dev/null || fail "$t.pvd does not name ${t}_00001.vti"
done
# the drift's map on its 32 x 24 lattice, the cover's on 200 m / 4 m = 50 x 50 cells
grep -q 'Name="snow_depth"' f_maps_00000.vti || fail "f_maps_00000.vti lacks snow_depth"
grep -q 'WholeExtent="0 31 0 23 0 0"' f_maps_00000.vti || fail "f_maps: $(grep -o 'WholeExtent="[^"]*"' f_maps_00000.vti)"
grep -q 'Name="surface_snow_thickness"' f_maps2_00000.vti || fail "f_maps2_00000.vti lacks surface_snow_thickness"
grep -q 'WholeExtent="0 49 0 49 0 0"' f_maps2_00000.vti || fail "f_maps2: $(grep -o 'WholeExtent="[^"]*"' f_maps2_00000.vti)"
if command -v ncdump > /dev/null; then
    ncdump -h f_maps2_00001.nc | grep -q "surface_snow_thickness(" || fail "f_maps2_00001.nc lacks surface_snow_thickness"
    ncdump -h f_maps_00001.nc | grep -q "snow_depth(" || fail "f_maps_00001.nc lacks snow_depth"
fi
finish
