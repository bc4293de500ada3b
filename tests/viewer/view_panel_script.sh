#!/bin/bash
# label: smoke
# The parameter panel and --script in a real window: the panel lists every key of
# `squall params <layer>` and of `squall params output` (it is generated from the same tables),
# each with the same live / rebuild flag (sq_param_live: one rule for both; a phenomenon without
# live changes, the snow cover, lists and shows every key as rebuild);
# a value the CLI refuses is refused with the CLI's message; a rebuild key restarts the scene, a
# live key (the camera, the urban dust concentration) does not; more dust (urban.concentration_kg_m3 from 6.4e-6 to 6e-5 kg/m3,
# visibility ~600 m -> ~60 m) lowers the picture's contrast as Koschmieder's law says it must
# (the apparent contrast of an object at distance d falls as exp(-beta_ext d)): the standard
# deviation of the luma drops to less than 60 % of the light-dust picture's.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"

cat > keys.txt <<'S'
panel-keys layers.dust dust_keys.txt
panel-keys output output_keys.txt
S
view urban-dust --size 160x96 --script keys.txt > out.txt 2> err.txt || fail "keys script exited $?: $(cat err.txt)"
"$SQ" params sandstorm | awk '/^  [a-z]/ {print $1, $NF}' > want_dust.txt
"$SQ" params output | awk '/^  [a-z]/ {print $1, $NF}' > want_output.txt
[ -s want_dust.txt ] || fail "squall params sandstorm listed no keys"
grep -q " live$" want_dust.txt && grep -q " rebuild$" want_dust.txt ||
    fail "squall params sandstorm: expected live and rebuild keys: $(cat want_dust.txt)"
grep -q "^wind.speed_mps live$" want_dust.txt || fail "sandstorm wind.speed_mps is live (docs/viewer.md)"
grep -q "^domain.nx rebuild$" want_dust.txt || fail "sandstorm domain.nx needs a rebuild"
diff want_dust.txt dust_keys.txt > /dev/null || fail "panel keys of layers.dust differ from squall params sandstorm: $(diff want_dust.txt dust_keys.txt | head -5)"
diff want_output.txt output_keys.txt > /dev/null || fail "panel keys of output differ from squall params output: $(diff want_output.txt output_keys.txt | head -5)"
if "$SQ" params snowcover > /dev/null 2>&1; then
    # a phenomenon without the apply_live hook: its table's live entries rebuild, in both
    cat > cover.yaml <<'Y'
name: cover
world:
  terrain: {kind: flat, size_m: [400, 400], resolution: [21, 21]}
layers:
  - type: snowcover
    name: snow
    flakes: {count: 100}
output: {width: 64, height: 36, video: ""}
Y
    printf 'panel-keys layers.snow cover_keys.txt\n' > cover.txt
    view cover.yaml --size 96x64 --script cover.txt > /dev/null 2> err.txt || fail "cover script exited $?: $(cat err.txt)"
    "$SQ" params snowcover | awk '/^  [a-z]/ {print $1, $NF}' > want_cover.txt
    [ -s want_cover.txt ] || fail "squall params snowcover listed no keys"
    diff want_cover.txt cover_keys.txt > /dev/null || fail "panel keys of the snow cover differ from squall params snowcover: $(diff want_cover.txt cover_keys.txt | head -5)"
fi

# a refused value: the CLI's message, exit 2, nothing written
cli_msg=$("$SQ" simulate urban-dust --frames 1 --set layers.dust.wind.speed_mps=-5 2>&1 >/dev/null | sed 's/^squall: //')
printf 'wait 1\nset layers.dust.wind.speed_mps -5\nscreenshot never.png\n' > bad.txt
view urban-dust --size 160x96 --script bad.txt > /dev/null 2> err.txt
rc=$?
[ "$rc" = 2 ] || fail "bad value: exit $rc, expected 2 ($(cat err.txt))"
grep -qF -- "bad.txt:2: $cli_msg" err.txt || fail "bad value: '$(cat err.txt)' does not carry the CLI's message '$cli_msg'"
[ -e never.png ] && fail "a screenshot was written after the refused value"

# live vs rebuild, and more dust -> lower contrast: the dust concentration is live (applied
# between two steps, the clock goes on), the number of size bins rebuilds (the clock restarts)
cat > dust.txt <<'S'
wait 2
screenshot light.png
print-time
set camera.fov_deg 55
set layers.dust.urban.concentration_kg_m3 [6e-5]
print-time
wait 1
screenshot heavy.png
print-time
set layers.dust.dust.bins 3
print-time
S
view urban-dust --size 320x180 --script dust.txt > out.txt 2> err.txt || fail "dust script exited $?: $(cat err.txt)"
grep -q "set camera.fov_deg = 55: live" out.txt || fail "camera.fov_deg not applied live: $(cat out.txt)"
grep -q "set layers.dust.urban.concentration_kg_m3 = \[6e-5\]: live (applied to frame" out.txt || fail "concentration not applied live: $(cat out.txt)"
grep -q "set layers.dust.dust.bins = 3: scene restarted" out.txt || fail "dust.bins not a rebuild: $(cat out.txt)"
grep -q "^shown layers.dust.urban.concentration_kg_m3 after" out.txt || fail "no draw showed the live change: $(cat out.txt)"
# the simulated time: on through the live change, back to the start after the rebuild
awk '/^time: / {print $5}' out.txt > times.txt
[ "$(wc -l < times.txt)" = 4 ] || fail "expected 4 times: $(cat out.txt)"
python3 - times.txt <<'PY' || fail "simulated time: $(cat out.txt)"
import sys
t = [float(x) for x in open(sys.argv[1])]
sys.exit(0 if t[0] > 0 and t[1] >= t[0] and t[2] > t[1] and t[3] < t[2] else 1)
PY
"$CMP" light.png heavy.png > cmp.json || fail "compare exited $?"
json cmp.json 'd["a"]["sd"] > 3.0 and d["b"]["black"] < 0.01'
json cmp.json 'd["b"]["sd"] < 0.6 * d["a"]["sd"]'
ls -a | grep -q "tmp" && fail "temporary files left: $(ls -a)"
finish
