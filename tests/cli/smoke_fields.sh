#!/bin/bash
# label: smoke
# Field output through the CLI: 3D fields and 2D maps as NetCDF-4 (HDF5 container) and VTK.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" simulate desert-sandstorm --frames 3 --fields f --set output.fields_every=2 \
    --set output.fields_format=both --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=16 \
    --set layers.storm.domain.nz=8 --quiet 2> err.txt || fail "simulate exited $?: $(cat err.txt)"
for n in f_00000.nc f_00002.nc f_maps_00000.nc f_maps_00002.nc; do
    [ "$(head -c 4 $n | od -An -c | tr -d ' ')" = '211HDF' ] || fail "$n is not a NetCDF-4/HDF5 file"
done
grep -q "dust_mass_concentration" f_00002.vti || fail "VTK file lacks the dust field"
grep -q "visibility_2m" f_maps_00002.vti || fail "VTK maps lack visibility_2m"
ls -a | grep -q "tmp" && fail "temporary files left"
finish
