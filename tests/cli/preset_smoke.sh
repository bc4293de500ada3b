#!/bin/bash
# Smoke test of one preset ($2): renders 3 small frames to MP4 with metrics and simulates 3 steps.
# (Not globbed as its own test: tests/CMakeLists.txt runs it once per preset.)
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
P="$2"
# a build without OpenGL or MP4 (-DSQ_WITH_GL=OFF ...) smoke-tests the simulation only
if "$SQ" info | grep -Eq "^features:.* gl( |$)" && "$SQ" info | grep -Eq "^features:.* mp4( |$)"; then
    "$SQ" render "$P" --frames 3 --size 160x96 -o p.mp4 --metrics m.csv --quiet 2> err.txt \
        || fail "render $P exited $?: $(cat err.txt)"
    [ -s p.mp4 ] || fail "$P: no video"
else
    "$SQ" simulate "$P" --frames 3 --metrics m.csv --quiet 2> err.txt \
        || fail "simulate $P exited $?: $(cat err.txt)"
fi
[ "$(wc -l < m.csv)" = 4 ] || fail "$P: metrics CSV should have a header and 3 rows: $(cat m.csv)"
grep -qi "nan" m.csv && fail "$P: NaN in metrics: $(cat m.csv)"
"$SQ" simulate "$P" --frames 3 --quiet 2> err.txt || fail "simulate $P exited $?: $(cat err.txt)"
finish
