#!/bin/bash
# label: smoke
# requires: gl mp4
# Renders a tiny scene to MP4 and PNG frames; checks the files, the summary and that no
# temporary file is left.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
"$SQ" render s.yaml -o clip.mp4 --json > sum.json 2> err.txt || fail "render exited $?: $(cat err.txt)"
[ -s clip.mp4 ] || fail "clip.mp4 missing"
python3 -c 'import json,sys; d=json.load(open("sum.json")); assert d["frames"]==2 and d["video"]=="clip.mp4", d' || fail "json summary"
"$SQ" render s.yaml -o frames --quiet || fail "png render exited $?"
[ -s frames/frame_00000.png ] && [ -s frames/frame_00001.png ] || fail "png frames missing"
ls -a | grep -q "tmp" && fail "temporary files left: $(ls -a)"
finish
