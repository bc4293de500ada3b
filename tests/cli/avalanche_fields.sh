#!/bin/bash
# label: smoke
# Avalanche outputs end to end through the CLI (issue 6 item 5): `squall simulate
# alpine-avalanche --json --fields` gives the front position and speed and the run-out with
# their units, and writes the deposit depth map as NetCDF-4 (CF units m), VTK and a 16-bit grey
# PNG at 1 mm per unit (north up) whose pixels integrate to the deposit volume of the metrics.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
SLOPE="$SRC/tests/cli/data/slope-avalanche.yaml"
"$SQ" simulate "$SLOPE" --frames 3 --fields f --set output.fields_every=2 \
    --set output.fields_format=both --metrics m.csv --json --threads 1 > s.json 2> err.txt \
    || fail "simulate exited $?: $(cat err.txt)"
for n in f_maps_00000.nc f_maps_00002.nc; do
    [ "$(head -c 4 $n | od -An -c | tr -d ' ')" = '211HDF' ] || fail "$n is not a NetCDF-4/HDF5 file"
    grep -aq "deposit_depth" $n || fail "$n lacks the deposit_depth variable"
    grep -aq "CF-1.8" $n || fail "$n lacks the CF convention"
done
grep -q "deposit_depth" f_maps_00002.vti || fail "VTK maps lack deposit_depth"
ls -a | grep -q "tmp" && fail "temporary files left"
head -1 m.csv | grep -q "slide.front_m \[m\],slide.front_speed_mps \[m/s\],slide.runout_m \[m\]" \
    || fail "metrics CSV header: $(head -1 m.csv)"
python3 - s.json f_deposit_depth_00000.png f_deposit_depth_00002.png > check.txt <<'PY' || fail "$(cat check.txt)"
import json, struct, sys, zlib
s = json.load(open(sys.argv[1]))["metrics"]
bad = []
for key, unit in [("front_m", "m"), ("front_speed_mps", "m/s"), ("runout_m", "m"),
                  ("alpha_deg", "deg"), ("deposit_depth_mean_m", "m"), ("deposit_depth_max_m", "m"),
                  ("deposit_volume_m3", "m3")]:
    m = s.get("slide." + key)
    if m is None or m.get("unit") != unit:
        bad.append("metric %s missing or not in %s: %s" % (key, unit, m))
for path in sys.argv[2:]:
    b = open(path, "rb").read()
    if b[:8] != b"\x89PNG\r\n\x1a\n":
        bad.append(path + " is not a PNG"); continue
    pos, idat = 8, b""
    while pos < len(b):
        n, = struct.unpack(">I", b[pos:pos + 4]); t = b[pos + 4:pos + 8]; d = b[pos + 8:pos + 8 + n]
        pos += 12 + n
        if t == b"IHDR": w, h, depth, ctype = struct.unpack(">IIBB", d[:10])
        if t == b"IDAT": idat += d
    # the scene's terrain: 500 x 400 m in 251 x 201 samples, one map cell of 2 m per sample
    if (w, h, depth, ctype) != (251, 201, 16, 0):
        bad.append("%s: %dx%d, %d bits, colour type %d; want 251x201 16-bit grey" % (path, w, h, depth, ctype))
        continue
    raw = zlib.decompress(idat); stride = 1 + 2 * w; prev = bytearray(2 * w); total = 0; top = 0
    for r in range(h):
        f, row = raw[r * stride], bytearray(raw[r * stride + 1:(r + 1) * stride])
        for i in range(len(row)):  # undo the PNG filters (bytes per pixel 2)
            a = row[i - 2] if i >= 2 else 0; up = prev[i]; c = prev[i - 2] if i >= 2 else 0
            if f == 1: row[i] = (row[i] + a) & 255
            elif f == 2: row[i] = (row[i] + up) & 255
            elif f == 3: row[i] = (row[i] + (a + up) // 2) & 255
            elif f == 4:
                p = a + up - c; pa, pb, pc = abs(p - a), abs(p - up), abs(p - c)
                row[i] = (row[i] + (a if pa <= pb and pa <= pc else up if pb <= pc else c)) & 255
        prev = row
        for i in range(w):
            v = (row[2 * i] << 8) | row[2 * i + 1]; total += v; top = max(top, v)
    vol = total * 1e-3 * 2.0 * 2.0
    print("%s: max %.3f m, volume %.1f m3" % (path, top * 1e-3, vol))
    want = s["slide.deposit_volume_m3"]
    if not (want["min"] * 0.99 <= vol <= want["max"] * 1.01):
        bad.append("%s integrates to %.1f m3; the metrics say %.1f..%.1f m3" % (path, vol, want["min"], want["max"]))
    if not (abs(top * 1e-3 - s["slide.deposit_depth_max_m"]["max"]) < 0.05 * s["slide.deposit_depth_max_m"]["max"] + 2e-3):
        bad.append("%s: max depth %.3f m vs metrics %.3f m" % (path, top * 1e-3, s["slide.deposit_depth_max_m"]["max"]))
print("\n".join(bad))
sys.exit(1 if bad else 0)
PY
cat check.txt
finish
