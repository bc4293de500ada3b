#!/usr/bin/python3
"""make_dem_seeds.py SAMPLE.tif OUTDIR — the seed corpus of the DEM fuzz harness
(tests/fuzz/corpus/dem/): small rasters of the kinds users give as world.terrain.dem, made with
GDAL from a real DEM: a 16 x 16 geographic crop (Int16, as SRTM), a projected Float32 crop with
no-data holes, and an ESRI ASCII grid without a CRS (the harness assigns one).

  /usr/bin/python3 scripts/reliability/make_dem_seeds.py \\
      data/dem/hef_srtm.tif tests/fuzz/corpus/dem
"""
import os
import sys

from osgeo import gdal

gdal.UseExceptions()


def main():
    src, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    gdal.Translate(os.path.join(out, "srtm_16x16_geographic.tif"), src, srcWin=[200, 150, 16, 16])
    utm = gdal.Warp("/vsimem/utm.tif", src, dstSRS="EPSG:32632", xRes=400, yRes=400,
                    outputType=gdal.GDT_Float32, outputBounds=[640000, 5170000, 644800, 5174800])
    band = utm.GetRasterBand(1)
    data = band.ReadAsArray()
    data[2:4, 3:6] = -9999.0
    band.WriteArray(data)
    band.SetNoDataValue(-9999.0)
    gdal.Translate(os.path.join(out, "utm_12x12_voids.tif"), utm)
    utm = None
    gdal.Unlink("/vsimem/utm.tif")
    with open(os.path.join(out, "grid_6x5_no_crs.asc"), "w") as f:
        f.write("ncols 6\nnrows 5\nxllcorner 640000\nyllcorner 5170000\ncellsize 30\n"
                "NODATA_value -9999\n")
        for j in range(5):
            f.write(" ".join(str(2500 + 7 * i + 11 * j) for i in range(6)) + "\n")


if __name__ == "__main__":
    main()
