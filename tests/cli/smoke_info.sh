#!/bin/bash
# label: smoke
# squall info / scenes / scene show / params.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" info > info.txt || fail "info exited $?"
grep -q "gl renderer:" info.txt || fail "info has no GL renderer line: $(cat info.txt)"
grep -q "threads:" info.txt || fail "info has no threads"
"$SQ" info --json | python3 -c 'import json,sys; d=json.load(sys.stdin); assert d["threads"]>=1 and "gl_renderer" in d, d' || fail "info --json"
"$SQ" scenes | grep -q terrain-flight || fail "scenes lists no terrain-flight"
"$SQ" scene show terrain-flight > tf.yaml || fail "scene show"
"$SQ" simulate tf.yaml --frames 2 --quiet || fail "the shown preset does not load back"
"$SQ" params output | grep -q "fps" || fail "params output"
"$SQ" params world | grep -q "terrain.kind" || fail "params world"
rm -f info.txt tf.yaml
finish
