#!/usr/bin/env python3
"""check_fields.py DIR — reads the field files a run left in DIR with tools that are not Squall
(netCDF4-python, ncdump, ncrcat when NCO is installed, VTK's XML readers) and checks what issue
17 part 7 asks of them. Expects, in DIR: sandstorm frames s_0000[0-2].nc, s_maps_0000[0-2].nc,
s_0000[0-2].vti and s.pvd (the time series index), and snowdrift frames d_*.nc with metrics
d.csv and the layer's snow.speedup in speedup.txt. Prints each failed check; exit 1 if any."""
import csv
import glob
import math
import os
import shutil
import subprocess
import sys

import netCDF4
import numpy as np

D = sys.argv[1]
fails = []

def check(cond, what):
    if not cond:
        fails.append(what)
        print("FAIL:", what)

def path(n):
    return os.path.join(D, n)

# ---- NetCDF: ncdump, UNLIMITED time, joining frames -------------------------------------------
frames = sorted(glob.glob(path("s_0000[0-9].nc")))
check(len(frames) == 3, "three sandstorm frames expected, found %d" % len(frames))
for f in frames + sorted(glob.glob(path("s_maps_*.nc"))):
    r = subprocess.run(["ncdump", "-h", f], capture_output=True, text=True)
    check(r.returncode == 0, "ncdump -h %s failed: %s" % (f, r.stderr.strip()))
    check("time = UNLIMITED" in r.stdout, "%s: time is not an UNLIMITED dimension" % f)
mf = netCDF4.MFDataset(frames)  # aggregates along the unlimited dimension, or refuses
t = mf.variables["time"][:]
check(len(t) == 3 and all(np.diff(t) > 0), "MFDataset time = %s; expected 3 increasing" % t)
mf.close()
if shutil.which("ncrcat"):
    out = path("joined.nc")
    r = subprocess.run(["ncrcat", "-O"] + frames + [out], capture_output=True, text=True)
    check(r.returncode == 0, "ncrcat failed: %s" % r.stderr.strip())
    if r.returncode == 0:
        with netCDF4.Dataset(out) as j:
            check(len(j.dimensions["time"]) == 3, "ncrcat joined %d records" % len(j.dimensions["time"]))
            check(j.variables["dust_mass_concentration"].shape[0] == 3, "joined field lacks records")
        os.remove(out)
else:
    print("note: ncrcat (NCO) not installed; joining checked with MFDataset only")

# ---- NetCDF: coordinates, fill values, levels ------------------------------------------------
with netCDF4.Dataset(frames[-1]) as ds:
    for c, sn in (("x", "projection_x_coordinate"), ("y", "projection_y_coordinate"),
                  ("z", "altitude"), ("time", "time")):
        v = ds.variables.get(c)
        check(v is not None and getattr(v, "standard_name", None) == sn,
              "%s: coordinate %s standard_name = %r, expected %r" %
              (frames[-1], c, getattr(v, "standard_name", None), sn))
    u = ds.variables["u"][:]
    check(np.ma.is_masked(u) and np.ma.count_masked(u) > 0,
          "u has no _FillValue cells: cells inside the terrain and obstacles read as data")
    z = ds.variables["z"][:]
    if np.ma.is_masked(u):
        # every masked column starts at the bottom: below-ground cells are fill, air above is data
        low = np.ma.getmaskarray(u)[0, 0, :, :]
        check(low.mean() > 0.5, "the lowest layer (z = %g m) is mostly data, not ground" % z[0])
        check(np.isfinite(u.compressed()).all(), "u holds non-finite data outside the fill")
    dust = ds.variables["dust_mass_concentration"]
    check(dust._FillValue > 1e36, "dust _FillValue %r" % dust._FillValue)
with netCDF4.Dataset(sorted(glob.glob(path("s_maps_*.nc")))[-1]) as ds:
    v = ds.variables["visibility_2m"]
    coord = getattr(v, "coordinates", "")
    check(coord != "" and coord in ds.variables, "visibility_2m has no level coordinate (%r)" % coord)
    if coord in ds.variables:
        h = ds.variables[coord]
        check(getattr(h, "standard_name", None) == "height" and float(h[...]) == 2.0,
              "visibility_2m level: %s = %s standard_name %r; expected height = 2 m" %
              (coord, h[...], getattr(h, "standard_name", None)))

# ---- snowdrift: concentration in physical units ----------------------------------------------
dframes = sorted(glob.glob(path("d_0*.nc")))
speedup = float(open(path("speedup.txt")).read())
rows = list(csv.reader(open(path("d.csv"))))
head, last = rows[0], rows[-1]
col = [i for i, h in enumerate(head) if h.startswith("snow.snow_airborne_kg")][0]
airborne_sim_kg = float(last[col])
with netCDF4.Dataset(dframes[-1]) as ds:
    c = ds.variables["blowing_snow_concentration"]
    check(c.units == "kg m-3", "concentration units %r" % c.units)
    x = ds.variables["x"][:]
    h = float(x[1] - x[0])
    total = float(np.ma.sum(c[:])) * h ** 3
    # the lattice time-lapses snowfall by snow.speedup: the physical airborne mass is the
    # simulated one divided by it
    check(airborne_sim_kg > 0, "no airborne snow in the test run")
    check(abs(total * speedup - airborne_sim_kg) <= 1e-3 * airborne_sim_kg,
          "sum of concentration x cell volume = %g kg; airborne metric / speedup = %g kg" %
          (total, airborne_sim_kg / speedup))
    check(np.ma.count_masked(ds.variables["u"][:]) > 0, "snowdrift u has no fill in solid cells")
with netCDF4.Dataset(sorted(glob.glob(path("d_maps_0*.nc")))[-1]) as ds:
    check(ds.variables["snow_depth"].dimensions == ("time", "y", "x") and
          not getattr(ds.variables["snow_depth"], "coordinates", ""),
          "snow_depth should be a surface field without a vertical coordinate")

# ---- VTK: the XML readers, the wind vector, NaN in solids, the .pvd series ---------------------
import vtk
from vtk.util.numpy_support import vtk_to_numpy
vtis = sorted(glob.glob(path("s_0000[0-9].vti")))
check(len(vtis) == 3, "three sandstorm .vti frames expected, found %d" % len(vtis))
r = vtk.vtkXMLImageDataReader()
r.SetFileName(vtis[-1])
r.Update()
img = r.GetOutput()
pd = img.GetPointData()
wind = pd.GetArray("wind")
check(wind is not None and wind.GetNumberOfComponents() == 3,
      "%s: no 3-component 'wind' array" % vtis[-1])
check(pd.GetArray("u") is None, "%s: u is still a separate array" % vtis[-1])
check(pd.GetVectors() is not None and pd.GetVectors().GetName() == "wind", "wind is not the Vectors")
if wind is not None:
    w = vtk_to_numpy(wind)
    check(np.isnan(w).any() and np.isfinite(w[~np.isnan(w).any(axis=1)]).all(),
          "wind: solid cells are not NaN (or air cells are not finite)")
pvd = path("s.pvd")
check(os.path.exists(pvd), "no time series index s.pvd")
if os.path.exists(pvd):
    # VTK's Python bindings in Debian 12 lack vtkXMLCollectionReader (ParaView's reader of .pvd):
    # the index is read as the XML it is, and every file it names with VTK's image reader
    import xml.etree.ElementTree as ET
    root = ET.parse(pvd).getroot()
    check(root.get("type") == "Collection", "s.pvd is not a VTK Collection")
    sets = root.findall("./Collection/DataSet")
    check(len(sets) == 3, "s.pvd lists %d data sets; expected 3" % len(sets))
    times = [float(e.get("timestep")) for e in sets]
    check(all(b > a for a, b in zip(times, times[1:])), "s.pvd times not increasing: %s" % times)
    for e in sets:
        f = os.path.join(D, e.get("file"))
        rr = vtk.vtkXMLImageDataReader()
        rr.SetFileName(f)
        rr.Update()
        tv = rr.GetOutput().GetFieldData().GetArray("TimeValue")
        check(tv is not None and tv.GetValue(0) == float(e.get("timestep")),
              "%s: TimeValue differs from the index's timestep %s" % (f, e.get("timestep")))

print("%d check(s) failed" % len(fails) if fails else "ok")
sys.exit(1 if fails else 0)
