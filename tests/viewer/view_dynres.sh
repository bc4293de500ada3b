#!/bin/bash
# label: smoke
# Dynamic resolution: while the camera moves (the script's orbit: a mouse-drag turn before each
# draw) the viewer draws at a reduced size and scales up; a screenshot is always drawn at full
# size. On the paused frame 0 of urban-dust, after the same four turns: the screenshot of a run
# with dynamic resolution equals the one of a --full-res run (SSIM >= 0.99, mean luma within
# 0.5 %), its draw was full size (shot_scale 1) while the turns were drawn reduced
# (draws_reduced >= 4, scale < 1; none with --full-res); the last reduced draw as shown is the
# same view at lower resolution: the same size, opaque, no black pixels, mean luma within 3 % and
# SSIM >= 0.6 against the full-size picture.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"

cat > dyn.txt <<'S'
wait 0
orbit 4 moving.png
screenshot still.png
S
view urban-dust --paused --size 320x180 --script dyn.txt --json > out.txt 2> err.txt || fail "dynres script exited $?: $(cat err.txt)"
tail -1 out.txt > dyn.json
json dyn.json 'd["draws_reduced"] >= 4 and d["reduced_scale_mean"] < 1.0'
json dyn.json 'd["shot_scale"] == 1.0'
sed 's/still.png/full.png/; s/ moving.png//' dyn.txt > full.txt
view urban-dust --paused --size 320x180 --script full.txt --json --full-res > outf.txt 2> err.txt || fail "--full-res script exited $?: $(cat err.txt)"
tail -1 outf.txt > full.json
json full.json 'd["draws_reduced"] == 0'
"$CMP" still.png full.png > cmp.json || fail "compare exited $?"
json cmp.json 'd["ssim"] >= 0.99'
json cmp.json 'abs(d["a"]["mean"] - d["b"]["mean"]) <= 0.005 * d["b"]["mean"]'
"$CMP" moving.png still.png > cmpm.json || fail "compare exited $?"
json cmpm.json 'd["a"]["width"] == 320 and d["a"]["height"] == 180'
json cmpm.json 'd["a"]["alpha_min"] == 255 and d["a"]["black"] < 0.01'
json cmpm.json 'abs(d["a"]["mean"] - d["b"]["mean"]) <= 0.03 * d["b"]["mean"]'
json cmpm.json 'd["ssim"] >= 0.6'
finish
