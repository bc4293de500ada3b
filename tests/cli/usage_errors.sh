#!/bin/bash
# label: unit
# Usage errors exit 2; --help on every sub-command exits 0 and prints usage. A path option's
# text that no scene file could hold is blamed on the option, at the byte of its own value.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
expect 2 "unknown command 'frobnicate'" -- frobnicate
expect 2 "unknown option '--bogus'" -- render --bogus
expect 2 "--frames needs a value" -- render --frames
expect 2 "--turbulence les: expected mixing-length, smagorinsky or tke" -- bench sandstorm --turbulence les
expect 2 "--closure 'les': must be none, smagorinsky or tke" -- validate lock-exchange --closure les
tiny_scene s.yaml
expect 2 "^squall: --metrics: byte 3 is a control character \(0x09\)" -- simulate s.yaml --metrics $'m.\tcsv'
expect 2 "^squall: -o: byte 5 is a control character \(0x0A\)" -- render s.yaml -o $'out/\nv.mp4'
for c in render simulate info scenes scene params bench validate visibility; do
    "$SQ" $c --help > h.txt 2>&1 || fail "squall $c --help exited $?"
    grep -qi "usage" h.txt || fail "squall $c --help prints no usage"
    rm -f h.txt
done
"$SQ" --help | grep -q "exit codes" || fail "squall --help"
finish
