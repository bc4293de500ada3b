#!/bin/bash
# label: unit
# Bad WRF input: exit 2, one line on stderr naming the file and the variable, nothing written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
WRF="$SRC/data/wrf/wrf_d01_allvars_cropped.nc"
PY=""
for p in python3 /usr/bin/python3; do
    if "$p" -c 'import netCDF4, numpy' 2>/dev/null; then PY="$p"; break; fi
done
[ -n "$PY" ] || { echo "FAIL: no python3 with netCDF4 and numpy (scripts/install-deps.sh installs python3-netcdf4)" >&2; exit 1; }
printf 'not a netcdf file\n' > junk.nc
head -c 300000 "$WRF" > trunc.nc
mkfifo fifo.nc
# corrupted copies of the sample, made with netCDF4-python
"$PY" - "$WRF" <<'PY' || fail "cannot make the bad files"
import shutil, sys
import netCDF4, numpy as np
src = sys.argv[1]
with netCDF4.Dataset("plain.nc", "w") as d:          # NetCDF, but not WRF output
    d.createDimension("a", 2)
    d.createVariable("b", "f4", ("a",))[:] = [1, 2]
KEEP = ("Times", "XLAT", "XLONG", "HGT", "PH", "PHB", "P", "PB", "T", "QVAPOR", "U", "V", "W",
        "QCLOUD", "QRAIN")
def copy(name, skip=(), attrs=None):
    with netCDF4.Dataset(src) as s, netCDF4.Dataset(name, "w") as d:
        for k, n in s.dimensions.items():
            d.createDimension(k, None if n.isunlimited() else len(n))
        for k in s.ncattrs():
            d.setncattr(k, s.getncattr(k))
        for k, a in (attrs or {}).items():
            d.setncattr(k, a)
        for k, v in s.variables.items():
            if k in skip or k not in KEEP:   # the WRF variables the reader uses: cheap copies
                continue
            o = d.createVariable(k, v.dtype, v.dimensions)
            o.setncatts({a: v.getncattr(a) for a in v.ncattrs()})
            o[:] = v[:]
copy("proj5.nc", attrs={"MAP_PROJ": np.int32(5)})
copy("shape.nc", skip=("QCLOUD",))
with netCDF4.Dataset(src) as s, netCDF4.Dataset("shape.nc", "a") as d:
    d.createVariable("QCLOUD", "f4", ("Time", "bottom_top", "south_north"))[:] = s["QCLOUD"][:, :, :, 0]
shutil.copy(src, "nan.nc")
with netCDF4.Dataset("nan.nc", "a") as d:
    q = d["QCLOUD"][:]
    q[1, 2, 3, 4] = np.nan
    d["QCLOUD"][:] = q
shutil.copy(src, "fill.nc")
with netCDF4.Dataset("fill.nc", "a") as d:
    d["T"].set_auto_mask(False)
    t = d["T"][:]
    t[2, 5, 1, 0] = netCDF4.default_fillvals["f4"]
    d["T"][:] = t
PY
expect 2 "junk.nc: not a NetCDF file" -- wrf info junk.nc
expect 2 "plain.nc: not WRF output: variable 'Times' is missing" -- wrf info plain.nc
expect 2 "trunc.nc: .*(truncated|corrupt|HDF)" -- wrf export trunc.nc --time 0 -o out.nc
expect 2 "wrf_d01_allvars_cropped.nc: time index 7 is out of range; the series has 4 times" -- wrf export "$WRF" --time 7 -o out.nc
expect 2 "proj5.nc: global attribute MAP_PROJ = 5: unknown map projection" -- wrf export proj5.nc --time 0 -o out.nc
expect 2 "shape.nc: variable 'QCLOUD' has the shape \(Time=4, bottom_top=27, south_north=8\); expected \(Time, bottom_top, south_north, west_east\)" -- wrf info shape.nc
expect 2 "nan.nc: variable 'QCLOUD' is NaN at \[Time 1, bottom_top 2, south_north 3, west_east 4\]" -- wrf export nan.nc --time 1 -o out.nc
expect 2 "nan.nc: variable 'QCLOUD' is NaN" -- wrf info nan.nc
expect 2 "fill.nc: variable 'T' holds the fill value .* at \[Time 2, bottom_top 5, south_north 1, west_east 0\]" -- wrf export fill.nc --time 2 -o out.nc
expect 2 "fifo.nc: is a FIFO; a WRF file must be a regular file" -- wrf info fifo.nc
expect 2 "missing.nc: cannot open: No such file" -- wrf info missing.nc
expect 2 "\-\-time abc: expected a stored time index" -- wrf export "$WRF" --time abc -o out.nc
expect 2 "exactly one of --time" -- wrf export "$WRF" -o out.nc
expect 2 "unknown option '--bogus'" -- wrf info "$WRF" --bogus
expect 2 "no WRF file given" -- wrf info
expect 2 "time -5 s is outside the series" -- wrf export "$WRF" --at -5 -o out.nc
# the other times of a file with a NaN still export; an existing output is kept
"$SQ" wrf export nan.nc --time 0 -o ok.nc 2>/dev/null || fail "time 0 of nan.nc should export"
expect 2 "ok.nc' exists; pass --overwrite" -- wrf export "$WRF" --time 0 -o ok.nc
finish
