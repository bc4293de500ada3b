#!/bin/bash
# label: smoke
# Save and record in a real window: a scene edited in the viewer (live keys: the exposure, applied
# to the frame shown while paused, and the camera) and saved as YAML renders with `squall render` to the frame the viewer showed (SSIM >= 0.98,
# mean luma within 1 %); a recording holds one H.264 frame per simulation frame shown, at the
# window's size rounded to even (3 frames, stepped one by one while paused), with the picture's brightness. Outputs are safe: no temporary
# left, existing files kept without --overwrite.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"

cat > edit.txt <<'S'
set output.exposure 1.5
record clip.mp4
wait 0
set camera.fov_deg 45
step
wait 1
step
wait-end
screenshot viewer.png
save saved.yaml
record-stop
S
view urban-dust --size 322x182 --frames 3 --paused --script edit.txt > out.txt 2> err.txt || fail "script exited $?: $(cat err.txt)"
[ -s saved.yaml ] || fail "no saved scene"
grep -q "exposure: 1.5" saved.yaml || fail "saved scene lacks the edited exposure: $(grep -n exposure saved.yaml)"
"$SQ" render saved.yaml --frames 3 --size 322x182 -o ref --quiet || fail "render of the saved scene exited $?"
"$CMP" viewer.png ref/frame_00002.png > cmp.json || fail "compare exited $?"
json cmp.json 'd["ssim"] >= 0.98'
json cmp.json 'abs(d["a"]["mean"] - d["b"]["mean"]) <= 0.01 * d["b"]["mean"]'

"$CMP" clip.mp4 > vid.json || fail "probe exited $?"
json vid.json 'd["video"]["width"] == 322 and d["video"]["height"] == 182'
json vid.json 'd["video"]["frames"] == 3 and d["video"]["codec"] == "h264"'
python3 - vid.json cmp.json <<'PY' || fail "video brightness differs from the screenshot's"
import json, sys
v = json.load(open(sys.argv[1]))["video"]; c = json.load(open(sys.argv[2]))["a"]
# Y of BT.601 video vs the screenshot's luma (both 0..255): within 8 %
sys.exit(0 if abs(v["mean_luma"] - c["mean"]) <= 0.08 * c["mean"] else 1)
PY
before=$(sha256sum saved.yaml)
printf 'save saved.yaml\n' > again.txt
expect 2 "saved.yaml.*exists" -- view urban-dust --script again.txt
[ "$before" = "$(sha256sum saved.yaml)" ] || fail "saved.yaml was replaced"
ls -a | grep -q "tmp" && fail "temporary files left: $(ls -a)"
finish
