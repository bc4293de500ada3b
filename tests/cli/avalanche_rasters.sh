#!/bin/bash
# label: physics
# Hazard rasters read back through GDAL (issue 16 item 3): `squall simulate --rasters DIR` on
# the real DEM (tests/cli/data/dem-avalanche.yaml: SRTM Hintereisferner, UTM 32N, the preset's
# release polygon) writes GeoTIFFs in the DEM's CRS; GDAL reads them back and
#  - every raster has the CRS EPSG:32632 and a north-up geotransform with the scene's 20 m cell;
#  - the deposit depth integrated over the raster (sum of depth x |cell area| from the
#    geotransform) equals the released volume within 1 % after 6 s of flow: summary.json's
#    released_volume_m3 and, independently, the particle count x spacing^3;
#  - the snow is at the right place: the deposit's centre of mass lies within 300 m of the
#    release polygon's centre, both in UTM 32N — the polygon transformed from its GeoJSON
#    (WGS 84 degrees) by OGR here, not by squall;
#  - the peak flow depth is >= the deposit depth everywhere and the peak speed > 0 where snow
#    passed;
#  - with --raster-format asc the deposit raster is an ESRI ASCII grid + .prj that GDAL reads
#    with the same CRS and the same volume.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
PY=python3
"$PY" -c 'import osgeo' 2> /dev/null || PY=/usr/bin/python3   # python3-gdal (Debian)
"$PY" -c 'import osgeo, numpy' || fail "no Python with GDAL (python3-gdal) and numpy"
SCENE="$SRC/tests/cli/data/dem-avalanche.yaml"
"$SQ" simulate "$SCENE" --rasters r --threads 1 > out.txt 2> err.txt \
    || fail "simulate exited $?: $(cat err.txt)"
"$SQ" simulate "$SCENE" --rasters a --raster-format asc --set output.frames=1 --threads 1 \
    > out2.txt 2> err2.txt || fail "simulate --raster-format asc exited $?: $(cat err2.txt)"
"$PY" - r a "$SRC/data/avalanche/hef_release.geojson" > check.txt <<'PY' || fail "$(cat check.txt)"
import json, sys
import numpy as np
from osgeo import gdal, ogr, osr
gdal.UseExceptions()
d, da, poly = sys.argv[1], sys.argv[2], sys.argv[3]
s = json.load(open(d + "/summary.json"))
m = s["metrics"]
bad = []
utm = osr.SpatialReference(); utm.ImportFromEPSG(32632)
utm.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
def read(path):
    """(CRS is EPSG:32632, geotransform, data with no-data as 0)"""
    ds = gdal.Open(path)
    srs = osr.SpatialReference(wkt=ds.GetProjection())
    srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    gt = ds.GetGeoTransform()
    b = ds.GetRasterBand(1)
    a = b.ReadAsArray().astype(np.float64)
    nd = b.GetNoDataValue()
    if nd is not None:
        a[a == nd] = 0.0
    return ("32632" if srs.IsSame(utm) else srs.GetName()), gt, a
names = [r["file"] for r in s["rasters"]]
for want in ["deposit_depth.tif", "peak_flow_depth.tif", "peak_speed.tif", "peak_pressure.tif",
             "travel_angle.tif"]:
    if want not in names:
        bad.append("summary.json lists no " + want)
grids = {}
for n in names:
    epsg, gt, a = read(d + "/" + n)
    grids[n] = (gt, a)
    if epsg != "32632":
        bad.append("%s: CRS %s, want EPSG:32632" % (n, epsg))
    if abs(gt[1] - 20.0) > 1e-9 or abs(gt[5] + 20.0) > 1e-9 or gt[2] != 0 or gt[4] != 0:
        bad.append("%s: geotransform %s is not north-up at 20 m" % (n, gt))
gt, dep = grids["deposit_depth.tif"]
vol = dep.sum() * abs(gt[1] * gt[5])
rel = m["slide.released_volume_m3"]["value"]
nvol = m["slide.particles"]["value"] * 2.5 ** 3
print("deposit volume from the GeoTIFF %.1f m3; released %.1f m3; particles x dx^3 %.1f m3"
      % (vol, rel, nvol))
for what, ref in [("released volume", rel), ("particles x dx^3", nvol)]:
    if abs(vol / ref - 1.0) > 0.01:
        bad.append("deposit volume %.1f m3 vs %s %.1f m3: %+.2f %%" % (vol, what, ref, 100 * (vol / ref - 1)))
# where the snow is, in UTM: cell centres from the geotransform
ny, nx = dep.shape
X = gt[0] + (np.arange(nx) + 0.5) * gt[1]
Y = gt[3] + (np.arange(ny) + 0.5) * gt[5]
cx = (dep.sum(axis=0) * X).sum() / dep.sum()
cy = (dep.sum(axis=1) * Y).sum() / dep.sum()
ll = osr.SpatialReference(); ll.ImportFromEPSG(4326)
ll.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
utm = osr.SpatialReference(); utm.ImportFromEPSG(32632)
utm.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
src = ogr.Open(poly)  # kept: its layer and feature die with it
feat = src.GetLayer(0).GetNextFeature()
g = feat.GetGeometryRef().Clone()
g.Transform(osr.CoordinateTransformation(ll, utm))
c = g.Centroid()
dist = ((cx - c.GetX()) ** 2 + (cy - c.GetY()) ** 2) ** 0.5
print("deposit centre E %.1f N %.1f; release polygon centre E %.1f N %.1f (%.0f m apart; "
      "the polygon's area %.0f m2)" % (cx, cy, c.GetX(), c.GetY(), dist, g.GetArea()))
if dist > 300.0:
    bad.append("the deposit's centre is %.0f m from the release polygon's" % dist)
pk = grids["peak_flow_depth.tif"][1]
if (pk < dep - 1e-4).any():
    bad.append("peak flow depth below the deposit depth in %d cells" % int((pk < dep - 1e-4).sum()))
sp = grids["peak_speed.tif"][1]
if not (sp[dep > 0.05] > 0).all():
    bad.append("peak speed 0 where snow lies")
# the ESRI ASCII grid of the 1-frame run (t = 0: the release itself)
epsg, gta, depa = read(da + "/deposit_depth.asc")
sa = json.load(open(da + "/summary.json"))["metrics"]
vola = depa.sum() * abs(gta[1] * gta[5])
print("ESRI ASCII: EPSG %s, volume %.1f m3 (released %.1f m3)"
      % (epsg, vola, sa["slide.released_volume_m3"]["value"]))
if epsg != "32632":
    bad.append("deposit_depth.asc: CRS %s, want EPSG:32632" % epsg)
if abs(vola / sa["slide.released_volume_m3"]["value"] - 1.0) > 0.01:
    bad.append("ESRI ASCII volume %.1f vs released %.1f m3" % (vola, sa["slide.released_volume_m3"]["value"]))
print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
cat check.txt
finish
