#!/bin/bash
# label: smoke
# `squall view PRESET --frames N --screenshot F` in a real window (Xvfb when there is no
# display): the GL area shows the library's renderer drawing into the widget's framebuffer. The
# screenshot must be a real picture (not blank, no black NaN/unwritten pixels) and the same frame
# that `squall render` makes of the scene: the same mean luminance within 3 % (the light reaching
# the camera does not depend on who owns the framebuffer) and SSIM >= 0.95. The safe-output
# rules hold: no temporary left, an existing file or the scene file itself is never replaced.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"
view urban-dust --frames 2 --size 320x180 --screenshot shot.png > out.txt 2> err.txt \
    || fail "view exited $?: $(cat err.txt)"
[ -s shot.png ] || fail "no screenshot"
"$SQ" render urban-dust --frames 2 --size 320x180 -o ref --quiet || fail "render exited $?"
"$CMP" shot.png ref/frame_00001.png > cmp.json || fail "compare exited $?"
json cmp.json 'd["a"]["width"] == 320 and d["a"]["height"] == 180'
json cmp.json 'd["a"]["sd"] > 3.0'                  # a picture, not a flat colour
json cmp.json 'd["a"]["black"] < 0.01'               # no black (NaN / unwritten) pixels
json cmp.json 'd["a"]["alpha_min"] == 255'           # opaque: the window shows it as it is
json cmp.json 'abs(d["a"]["mean"] - d["b"]["mean"]) <= 0.03 * d["b"]["mean"]'
json cmp.json 'd["ssim"] >= 0.95'
ls -a | grep -q "tmp" && fail "temporary files left: $(ls -a)"

# an existing screenshot is not replaced without --overwrite; the scene file is never written
before=$(sha256sum shot.png)
expect 2 "shot.png.*exists" -- view urban-dust --frames 1 --screenshot shot.png
[ "$before" = "$(sha256sum shot.png)" ] || fail "shot.png was replaced"
tiny_scene s.yaml
expect 2 "s.yaml.*scene file.*never written" -- view s.yaml --frames 1 --screenshot s.yaml --overwrite
# nor the scene through a hard link, nor a file the scene reads (the DEM), nor the script itself
ln s.yaml hard.yaml
expect 2 "hard.yaml.*is the scene file.*never written" -- view s.yaml --frames 1 --screenshot hard.yaml --overwrite
cp "$SRC/tests/cli/data/dem-avalanche.yaml" dem.yaml
sed -i -e "s#../../../data/#$SRC/data/#" dem.yaml
cp "$SRC/data/dem/hef_srtm.tif" dem.tif
sed -i -e "s#dem: $SRC/data/dem/hef_srtm.tif#dem: dem.tif#" dem.yaml
grep -q "dem: dem.tif" dem.yaml || fail "dem.yaml not rewritten"
expect 2 "dem.tif' is the DEM.*never written" -- view dem.yaml --frames 1 --screenshot dem.tif --overwrite
printf 'screenshot self.txt\n' > self.txt
expect 2 "'self.txt' is the script being run.*never written" -- view s.yaml --script self.txt --overwrite
printf 'panel-keys camera self2.txt\n' > self2.txt
expect 2 "'self2.txt' is the script being run" -- view s.yaml --script self2.txt --overwrite
expect 2 "screenshot.*needs --frames" -- view urban-dust --screenshot x.png
expect 2 "unknown option '--bogus'" -- view --bogus
finish
