#!/bin/bash
# label: smoke
# Field files that the standard tools accept (issue 17 part 7): a small sandstorm and snowdrift
# run, their NetCDF and VTK files read by netCDF4-python, ncdump, ncrcat (NCO, if installed) and
# VTK's XML readers (tests/reliability/check_fields.py). A CF compliance checker is not packaged
# in Debian 12 (cfchecker is on PyPI only), so CF rules are checked attribute by attribute there.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
PY=/usr/bin/python3
[ -x "$PY" ] || PY=python3
"$PY" -c "import netCDF4, vtk" 2>/dev/null || { echo "skipped: python3-netcdf4 / python3-vtk9 missing"; exit 0; }
"$SQ" simulate desert-sandstorm --frames 3 --fields s --metrics s.csv --set output.fields_every=1 \
    --set output.fields_format=both --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=16 \
    --set layers.storm.domain.nz=8 --quiet 2> err.txt || fail "sandstorm simulate exited $?: $(cat err.txt)"
cat > d.yaml <<'YAML'
seed: 3
world:
  terrain: {kind: flat, material: snow, size_m: [200, 200], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
layers:
  - type: snowdrift
    name: snow
    domain: {nx: 32, ny: 24, nz: 16, cell_size_m: 2}
    wind: {speed_mps: 6}
    snow: {snowfall_mmh: 4, speedup: 2000}
    draw: {flakes: 100}
output: {fps: 4, frames: 6, fields_every: 5}
YAML
echo 2000 > speedup.txt
"$SQ" simulate d.yaml --fields d --metrics d.csv --quiet 2> err.txt || fail "snowdrift simulate exited $?: $(cat err.txt)"
"$PY" "$SRC/tests/reliability/check_fields.py" "$T" || fail "field files do not pass the independent readers"
finish
