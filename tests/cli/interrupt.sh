#!/bin/bash
# label: unit
# requires: gl
# Interruption is consistent (issue 17 parts 2 and 3): SIGINT or SIGTERM, during the scene's
# set-up (a large terrain being generated) or during the frames, stops the run (exit 1,
# "interrupted"), and leaves nothing but the metrics rows so far, as NAME.partial.csv: no
# frame, no field file, no temporary; the same whether the frames directory existed or not; a
# file the run did not make is never removed; and a re-run is not blocked by the first one. The
# generous limits only keep a broken build from hanging the suite; the time to answer is measured
# in docs/reliability.md, not here.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
# wait_for FILE: up to 120 s for FILE to appear (the run has started its frames)
wait_for() { for i in $(seq 1 1200); do [ -e "$1" ] && return 0; sleep 0.1; done; return 1; }
# wait_handler PID: until the process catches SIGINT (a background job starts with SIGINT
# ignored, so a signal sent before squall installs its handler would be lost)
wait_handler() {
    for i in $(seq 1 1200); do
        local m
        m=$(awk '/^SigCgt:/ {print $2}' /proc/$1/status 2>/dev/null)
        [ -n "$m" ] && [ $(( 0x$m & 2 )) != 0 ] && return 0
        sleep 0.1
    done
    return 1
}
tiny_scene s.yaml
sed -i 's/frames: 2, video: out.mp4/frames: 400, video: ""/' s.yaml
cat >> s.yaml <<'YAML'
layers:
  - {type: snowdrift, name: snow, domain: {nx: 16, ny: 16, nz: 8, cell_size_m: 10}, draw: {flakes: 10}}
YAML

# during the frames: SIGINT into a new frames directory, SIGTERM into an existing one (each run
# takes seconds to reach its frames on a loaded machine, so not the whole 2 x 2 matrix)
for case in INT:no TERM:yes; do
    sig=${case%:*} existing=${case#*:}
    {
        d=run-$sig-$existing
        mkdir $d
        [ $existing = yes ] && { mkdir $d/frames; echo mine > $d/frames/notes.txt; }
        "$SQ" render s.yaml -o $d/frames --metrics $d/m.csv --fields $d/f \
            --set output.fields_every=1 --set output.fields_format=vtk 2> $d/err.txt &
        pid=$!
        # the run is in its frames once its metrics temporary exists
        wait_for "$(dirname $d/m.csv)/.m.csv.tmp-$pid-0" || fail "$d: the run did not start"
        sleep 1
        kill -$sig $pid
        wait $pid
        rc=$?
        [ "$rc" = 1 ] || fail "$d: exit $rc after SIG$sig, expected 1"
        grep -q "interrupted at frame" $d/err.txt || fail "$d: $(cat $d/err.txt)"
        grep -q "m.partial.csv" $d/err.txt || fail "$d: the partial metrics are not named: $(cat $d/err.txt)"
        [ "$(tail -1 $d/err.txt | grep -c .)" = 1 ] || fail "$d: $(cat $d/err.txt)"
        left=$(cd $d && find . -type f ! -name err.txt ! -name m.partial.csv ! -path ./frames/notes.txt | sort)
        [ -z "$left" ] || fail "$d: files left after SIG$sig: $left"
        [ -s $d/m.partial.csv ] && [ "$(head -1 $d/m.partial.csv | cut -c1-12)" = "frame,time_s" ] ||
            fail "$d: m.partial.csv is not the metrics so far"
        if [ $existing = yes ]; then
            [ "$(cat $d/frames/notes.txt 2>/dev/null)" = mine ] || fail "$d: a file the run did not make was touched"
        else
            [ -e $d/frames ] && fail "$d: the frames directory the run made is still there"
        fi
    }
done
# the re-run of an interrupted run is not blocked (nothing of it is there)
"$SQ" render s.yaml -o run-INT-no/frames --metrics run-INT-no/m.csv --frames 2 --quiet 2> err.txt ||
    fail "re-run after the interruption: $(cat err.txt)"
[ -s run-INT-no/frames/frame_00001.png ] || fail "the re-run wrote no frames"

# during the set-up: a 4097 x 4097 terrain of 12 octaves takes seconds to generate
cat > big.yaml <<'YAML'
world: {terrain: {kind: hills, resolution: [4097, 4097], octaves: 12}}
output: {frames: 1}
YAML
"$SQ" simulate big.yaml --metrics big.csv 2> err.txt &
pid=$!
wait_handler $pid || fail "set-up: no SIGINT handler"
sleep 1
kill -INT $pid
wait $pid
rc=$?
[ "$rc" = 1 ] || fail "set-up: exit $rc after SIGINT, expected 1 ($(cat err.txt))"
grep -q "interrupted while generating the terrain" err.txt || fail "set-up: $(cat err.txt)"
[ -e big.csv ] && fail "set-up: big.csv written"
finish
