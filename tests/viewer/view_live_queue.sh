#!/bin/bash
# label: smoke
# Two live changes made within one display frame both apply (the simulation thread takes them in
# order, each on the scene the previous one left): `send` gives the urban dust concentration
# without waiting, `set` the exposure at once after it, in the same frame. Both are reported
# applied by the simulation thread (sq_run_apply_live changed a key for each), the scene saved
# afterwards has both; a refused value among queued changes is reported with the CLI's message
# while the changes around it apply; a rebuild key right after a live change rebuilds a scene
# that has both.
. "$SQ_SOURCE_DIR/tests/viewer/view_lib.sh"

cat > two.txt <<'S'
wait 1
send layers.dust.urban.concentration_kg_m3 [6e-5]
set output.exposure 2.5
save saved.yaml
S
view urban-dust --size 160x96 --script two.txt > out.txt 2> err.txt || fail "script exited $?: $(cat err.txt)"
grep -q "^change layers.dust.urban.concentration_kg_m3 = \[6e-5\]: applied to frame [0-9]* ([1-9][0-9]* changed)" out.txt ||
    fail "the first of two changes in one frame was not applied: $(cat out.txt)"
grep -q "^change output.exposure = 2.5: applied to frame [0-9]* ([1-9][0-9]* changed)" out.txt ||
    fail "the second of two changes in one frame was not applied: $(cat out.txt)"
# the saved scene (the user's, as edited) has both
conc=$(awk '/concentration_kg_m3:/ {f = 1; print; next} f && /^ *- / {print; next} {f = 0}' saved.yaml | tr -d ' \n')
[ "$conc" = "concentration_kg_m3:-6e-5" ] || [ "$conc" = "concentration_kg_m3:[6e-5]" ] ||
    fail "the saved scene lacks the first change: '$conc'"
grep -q "^  exposure: 2.5$" saved.yaml || fail "the saved scene lacks the second change: $(grep exposure saved.yaml)"

# a refused value between two good ones sent in the same frame: the good ones apply, the refusal
# stops the script with the line that sent it and the CLI's message (exit 2)
cli_msg=$("$SQ" simulate urban-dust --frames 1 --set layers.dust.wind.speed_mps=-5 2>&1 >/dev/null | sed 's/^squall: //')
cat > three.txt <<'S'
wait 1
send output.exposure 2
send layers.dust.wind.speed_mps -5
set layers.dust.urban.stage_s 6
S
view urban-dust --size 160x96 --script three.txt > out3.txt 2> err3.txt
rc=$?
[ "$rc" = 2 ] || fail "a refused queued change: exit $rc, expected 2 ($(cat err3.txt))"
grep -qF -- "three.txt:3: $cli_msg" err3.txt || fail "refusal: '$(cat err3.txt)' does not carry the CLI's message '$cli_msg'"
grep -q "^change output.exposure = 2: applied" out3.txt || fail "the change before the refused one: $(cat out3.txt)"
grep -q "^change layers.dust.urban.stage_s = 6: applied" out3.txt || fail "the change after the refused one: $(cat out3.txt)"
grep -q "^change layers.dust.wind.speed_mps = -5: refused" out3.txt || fail "the refused one: $(cat out3.txt)"
# a live change, then a rebuild key in the same frame: the rebuilt scene has both (the rebuild
# waits for the live change before it instead of dropping it)
cat > four.txt <<'S'
wait 1
send layers.dust.urban.concentration_kg_m3 [6e-5]
set layers.dust.dust.bins 3
save saved4.yaml
S
view urban-dust --size 160x96 --script four.txt > out4.txt 2> err4.txt || fail "four.txt exited $?: $(cat err4.txt)"
grep -q "^change layers.dust.urban.concentration_kg_m3 = \[6e-5\]: applied" out4.txt || fail "live change before a rebuild: $(cat out4.txt)"
grep -q "^set layers.dust.dust.bins = 3: scene restarted" out4.txt || fail "the rebuild key: $(cat out4.txt)"
conc=$(awk '/concentration_kg_m3:/ {f = 1; print; next} f && /^ *- / {print; next} {f = 0}' saved4.yaml | tr -d ' \n')
[ "$conc" = "concentration_kg_m3:-6e-5" ] || [ "$conc" = "concentration_kg_m3:[6e-5]" ] ||
    fail "the rebuilt scene lost the live change before it: '$conc'"
grep -q "^      bins: 3$" saved4.yaml || fail "the saved scene lacks the rebuild key: $(grep bins saved4.yaml)"
finish
