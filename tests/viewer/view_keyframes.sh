#!/bin/bash
# label: smoke
# Camera keyframes in a real window: two views recorded as keys of camera.path (script
# `keyframe`, as key K) at the video times of the frames shown (0 and 1/24 s), saved as YAML that
# `squall render` follows: its frames 0 and 1 are the viewer's pictures of those views (SSIM >=
# 0.98, mean luma within 1 %). A key before the last one is refused (keys must increase in time).
# The near field is off: its particles are placed around the camera of each simulation step.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"

cat > kf.txt <<'S'
wait 0
set camera.position [-300, 0, 9]
set camera.target [300, 0, 30]
keyframe
screenshot k0.png
step
wait 1
set camera.position [-200, 60, 40]
set camera.target [300, -40, 20]
keyframe
screenshot k1.png
save keys.yaml
S
view urban-dust --size 322x182 --frames 3 --paused --set layers.dust.near.enabled=false --script kf.txt > out.txt 2> err.txt || fail "script exited $?: $(cat err.txt)"
grep -q "^keyframe 0 at t = 0 s" out.txt || fail "first keyframe: $(cat out.txt)"
grep -q "^keyframe 1 at t = 0.0416667 s" out.txt || fail "second keyframe (1/24 s): $(cat out.txt)"
[ -s keys.yaml ] || fail "no saved scene"
"$SQ" render keys.yaml --frames 2 --size 322x182 -o ref --quiet || fail "render of the saved scene exited $?"
for k in 0 1; do
    "$CMP" k$k.png ref/frame_0000$k.png > cmp$k.json || fail "compare $k exited $?"
    json cmp$k.json 'd["ssim"] >= 0.98'
    json cmp$k.json 'abs(d["a"]["mean"] - d["b"]["mean"]) <= 0.01 * d["b"]["mean"]'
done
# the two views differ (the path is not one fixed camera)
"$CMP" k0.png k1.png > cmp01.json || fail "compare exited $?"
json cmp01.json 'd["ssim"] < 0.9'

# a key before the last: the scene was restarted (a rebuild key) after a key at frame 1
cat > back.txt <<'S'
wait 0
step
wait 1
keyframe
set layers.dust.dust.bins 3
wait 0
keyframe
S
view urban-dust --size 160x96 --paused --script back.txt > out2.txt 2> err2.txt
rc=$?
[ "$rc" = 2 ] || fail "key before the last: exit $rc, expected 2 ($(cat err2.txt))"
grep -q "keys must increase in time" err2.txt || fail "key before the last: $(cat err2.txt)"
ls -a | grep -q "tmp" && fail "temporary files left: $(ls -a)"
finish
