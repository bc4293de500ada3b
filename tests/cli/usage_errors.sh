#!/bin/bash
# label: unit
# Usage errors exit 2; --help on every sub-command exits 0 and prints usage.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
expect 2 "unknown command 'frobnicate'" -- frobnicate
expect 2 "unknown option '--bogus'" -- render --bogus
expect 2 "--frames needs a value" -- render --frames
expect 2 "--turbulence les: expected mixing-length, smagorinsky or tke" -- bench sandstorm --turbulence les
expect 2 "--closure 'les': must be none, smagorinsky or tke" -- validate lock-exchange --closure les
for c in render simulate info scenes scene params bench validate visibility; do
    "$SQ" $c --help > h.txt 2>&1 || fail "squall $c --help exited $?"
    grep -qi "usage" h.txt || fail "squall $c --help prints no usage"
    rm -f h.txt
done
"$SQ" --help | grep -q "exit codes" || fail "squall --help"
finish
