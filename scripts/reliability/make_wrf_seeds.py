#!/usr/bin/python3
"""make_wrf_seeds.py SAMPLE.nc OUTDIR — the seed corpus of the WRF fuzz harness
(tests/fuzz/corpus/wrf/): small netCDF-3 crops of a real wrfout file. netCDF-3 because its
parsing is libnetcdf's own small code (HDF5, behind netCDF-4, is not hardened against hostile
files and would make the fuzzer find HDF5's bugs instead of squall's). Each seed keeps only what
the reader uses: the projection attributes, Times, XLAT/XLONG, HGT, the pressure, geopotential,
temperature and moisture fields and the staggered winds, cropped to a few points.

  /usr/bin/python3 scripts/reliability/make_wrf_seeds.py \\
      data/wrf/wrf_d01_allvars_cropped.nc tests/fuzz/corpus/wrf
"""
import os
import sys

import netCDF4
import numpy as np

ATTRS = ["TITLE", "MAP_PROJ", "DX", "DY", "TRUELAT1", "TRUELAT2", "STAND_LON", "MOAD_CEN_LAT",
         "CEN_LAT", "CEN_LON", "POLE_LAT", "POLE_LON", "MP_PHYSICS"]
VARS = ["Times", "XLAT", "XLONG", "HGT", "P", "PB", "PH", "PHB", "T", "QVAPOR", "QCLOUD", "QRAIN",
        "QICE", "QSNOW", "QGRAUP", "QNICE", "QNRAIN", "U", "V", "W"]


def crop(src, path, nx, ny, nz, times, hydrometeors=True):
    sizes = {"Time": None, "west_east": nx, "south_north": ny, "bottom_top": nz,
             "west_east_stag": nx + 1, "south_north_stag": ny + 1, "bottom_top_stag": nz + 1}
    out = netCDF4.Dataset(path, "w", format="NETCDF3_CLASSIC")
    for a in ATTRS:
        if a in src.ncattrs():
            out.setncattr(a, src.getncattr(a))
    out.createDimension("Time", None)
    out.createDimension("DateStrLen", 19)
    for name, n in sizes.items():
        if n is not None:
            out.createDimension(name, n)
    for v in VARS:
        if v not in src.variables:
            continue
        if not hydrometeors and v.startswith("Q") and v not in ("QVAPOR", "QCLOUD"):
            continue
        var = src.variables[v]
        dims = tuple("DateStrLen" if d == "string19" else d for d in var.dimensions)
        o = out.createVariable(v, var.dtype, dims)
        index = []
        for d in var.dimensions:
            if d == "Time":
                index.append(list(times))
            elif d in sizes:
                index.append(slice(0, sizes[d]))
            else:
                index.append(slice(None))
        o[:] = np.asarray(var[tuple(index)])
    out.close()


def main():
    src = netCDF4.Dataset(sys.argv[1])
    os.makedirs(sys.argv[2], exist_ok=True)
    crop(src, os.path.join(sys.argv[2], "crop_3x3x3_t2.nc"), 3, 3, 3, [0, 1])
    crop(src, os.path.join(sys.argv[2], "crop_2x2x2_t1_warm.nc"), 2, 2, 2, [2], hydrometeors=False)
    src.close()


if __name__ == "__main__":
    main()
