#!/bin/bash
# label: unit
# `squall wrf info` and `squall wrf export` on the real sample (data/wrf): the exported CF-1.8
# fields are checked against an independent computation from the file with netCDF4-python and
# numpy (the formulas wrf-python matches: z within 0.01 m, p exact, T within 1e-3 K).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
WRF="$SRC/data/wrf/wrf_d01_allvars_cropped.nc"
PY=""
for p in python3 /usr/bin/python3; do
    if "$p" -c 'import netCDF4, numpy' 2>/dev/null; then PY="$p"; break; fi
done
[ -n "$PY" ] || { echo "FAIL: no python3 with netCDF4 and numpy (scripts/install-deps.sh installs python3-netcdf4)" >&2; exit 1; }

"$SQ" wrf info "$WRF" > info.txt 2> info.err || fail "wrf info: exit $? ($(cat info.err))"
for pat in "10 x 8 mass points x 27 levels" "Lambert conformal \(MAP_PROJ 1\)" \
           "2005-09-21_09:00:00" "cloud_water \(QCLOUD\)" "graupel \(QGRAUP\)" "\+proj=lcc"; do
    grep -Eq "$pat" info.txt || fail "wrf info: no '$pat' in: $(cat info.txt)"
done
"$SQ" wrf info "$WRF" --json > info.json || fail "wrf info --json"
"$PY" - info.json <<'PY' || fail "info --json content"
import json, sys
d = json.load(open(sys.argv[1]))
assert (d["nx"], d["ny"], d["nz"]) == (10, 8, 27), d
assert d["map_proj"] == 1 and len(d["times"]) == 4 and d["times"][3]["seconds"] == 32400
assert d["hydrometeors"] == ["cloud_water", "cloud_ice", "snow", "rain", "graupel"], d["hydrometeors"]
lo, hi = d["ranges"]["terrain_m"]
assert abs(lo - 4484.35) < 0.005 and abs(hi - 5499.41) < 0.005, (lo, hi)
PY

"$SQ" wrf export "$WRF" --time 1 -o t1.nc 2> exp.err || fail "wrf export: exit $? ($(cat exp.err))"
"$SQ" wrf export "$WRF" --at 5400 -o half.nc 2> exp2.err || fail "wrf export --at: $(cat exp2.err)"
"$SQ" wrf export "$WRF" --time 0 -o t0.nc 2> exp3.err || fail "wrf export --time 0: $(cat exp3.err)"
"$PY" - "$WRF" t1.nc half.nc t0.nc <<'PY' || fail "exported fields differ from the independent computation"
import sys
import numpy as np
import netCDF4
src, out, half, out0 = sys.argv[1:5]
w = netCDF4.Dataset(src)
w.set_auto_mask(False)
def derived(t):
    g = lambda v: w[v][t]
    zs = (g("PH").astype(np.float64) + g("PHB")) / 9.81
    z = 0.5 * (zs[:-1] + zs[1:])
    p = g("P") + g("PB")                       # float32 + float32, as wrf-python
    theta = g("T").astype(np.float64) + 300.0
    tk = theta * (p.astype(np.float64) / 1e5) ** (287.0 / 1004.5)
    q = {v: np.maximum(g(v).astype(np.float64), 0.0) for v in ("QVAPOR", "QCLOUD", "QRAIN", "QICE", "QSNOW", "QGRAUP")}
    rho = p / (287.0 * tk * (1.0 + 0.608 * q["QVAPOR"]))
    vol = (1 + q["QVAPOR"]) / rho + (q["QCLOUD"] + q["QRAIN"]) / 1000.0 + (q["QICE"] + q["QSNOW"] + q["QGRAUP"]) / 917.0
    cw, ci = 1000 * q["QCLOUD"] / vol, 1000 * q["QICE"] / vol
    beta = 3 * cw * 1e-3 / (2 * 1000.0 * 10e-6) + 3 * ci * 1e-3 / (2 * 917.0 * 25e-6)
    tau = (beta * (zs[1:] - zs[:-1])).sum(axis=0)
    u = 0.5 * (g("U")[..., :-1].astype(np.float64) + g("U")[..., 1:])
    hgt = w["HGT"][t] if w["HGT"].ndim == 3 else w["HGT"][:]   # no Time dimension in this file
    return dict(z=z, p=p, theta=theta, tk=tk, rho=rho, cw=cw, ci=ci, tau=tau, u=u, hgt=hgt)
e = derived(1)
o = netCDF4.Dataset(out)
o.set_auto_mask(False)
assert o.Conventions == "CF-1.8", o.Conventions
for v in ("z", "pressure", "theta", "temperature", "cloud_water", "cloud_ice", "extinction"):
    assert o[v].dimensions == ("bottom_top", "south_north", "west_east"), (v, o[v].dimensions)
    assert o[v].grid_mapping == "crs" and "lat lon" in o[v].coordinates, v
assert o["cloud_optical_depth"].dimensions == ("south_north", "west_east")
assert o["z"].units == "m" and o["pressure"].units == "Pa" and o["temperature"].units == "K"
assert o["cloud_water"].units == "g m-3" and o["cloud_ice"].units == "g m-3"
assert o["crs"].grid_mapping_name == "lambert_conformal_conic"
assert list(o["crs"].standard_parallel) == [30.0, 35.0] and o["crs"].earth_radius == 6370000.0
assert o["lat"].standard_name == "latitude" and o["lon"].units == "degrees_east"
assert o["time"].units == "seconds since 2005-09-21 00:00:00" and o["time"][...] == 10800.0
checks = [
    ("z", np.abs(o["z"][:] - e["z"]).max(), 0.01),
    ("pressure", np.abs(o["pressure"][:] - e["p"]).max(), 0.0),
    ("temperature", np.abs(o["temperature"][:] - e["tk"]).max(), 1e-3),
    ("theta", np.abs(o["theta"][:] - e["theta"]).max(), 1e-4),
    ("air_density", (np.abs(o["air_density"][:] - e["rho"]) / e["rho"]).max(), 1e-6),
    ("cloud_water", np.abs(o["cloud_water"][:] - e["cw"]).max(), 1e-6 * e["cw"].max()),
    ("cloud_ice", np.abs(o["cloud_ice"][:] - e["ci"]).max(), 1e-6 * e["ci"].max()),
    ("cloud_optical_depth", np.abs(o["cloud_optical_depth"][:] - e["tau"]).max(), 1e-5 * e["tau"].max()),
    ("u", np.abs(o["u"][:] - e["u"]).max(), 1e-5),
    ("terrain_height", np.abs(o["terrain_height"][:] - e["hgt"]).max(), 0.0),
    ("lat", np.abs(o["lat"][:] - w["XLAT"][:]).max(), 0.0),
    ("lon", np.abs(o["lon"][:] - w["XLONG"][:]).max(), 0.0),
    ("x spacing", np.abs(np.diff(o["x"][:]) - 30000.0).max(), 1e-6),
]
bad = [f"{n}: {d:.3g} > {tol:.3g}" for n, d, tol in checks if not d <= tol]
assert not bad, bad
assert e["tau"].max() > 1.0, e["tau"].max()   # the sample has real clouds
# time 0: the reference number of wrf_format.md
o0 = netCDF4.Dataset(out0)
assert abs(o0["z"][0, 0, 0] - 4824.1283) < 0.01, o0["z"][0, 0, 0]
# --at 5400 s: halfway between stored times 0 and 1
h = netCDF4.Dataset(half)
e0 = derived(0)
assert np.abs(h["z"][:] - 0.5 * (e0["z"] + e["z"])).max() < 0.01
assert np.abs(h["temperature"][:] - 0.5 * (e0["tk"] + e["tk"])).max() < 1e-3
PY
finish
