#!/bin/bash
# label: smoke
# squall info / scenes / scene show / params.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" info > info.txt || fail "info exited $?"
grep -q "threads:" info.txt || fail "info has no threads"
# without --threads the worker count is OpenMP's: OMP_NUM_THREADS when set (mpirun -x
# OMP_NUM_THREADS=1 gives each rank one thread, docs/mpi.md); --threads wins over it
if grep -Eq "^features:.* openmp( |$)" info.txt; then
    t=$(OMP_NUM_THREADS=3 "$SQ" info | sed -n 's/^threads: *//p')
    [ "$t" = 3 ] || fail "OMP_NUM_THREADS=3: info says threads $t"
    t=$(OMP_NUM_THREADS=3 "$SQ" info --threads 5 | sed -n 's/^threads: *//p')
    [ "$t" = 5 ] || fail "OMP_NUM_THREADS=3 --threads 5: info says threads $t"
fi
if grep -Eq "^features:.* gl( |$)" info.txt; then
    grep -q "gl renderer:" info.txt || fail "info has no GL renderer line: $(cat info.txt)"
    "$SQ" info --json | python3 -c 'import json,sys; d=json.load(sys.stdin); assert d["threads"]>=1 and "gl_renderer" in d, d' || fail "info --json"
else # built without OpenGL (-DSQ_WITH_GL=OFF): it says so
    grep -q "built without OpenGL" info.txt || fail "info does not say GL is not built in: $(cat info.txt)"
    "$SQ" info --json | python3 -c 'import json,sys; d=json.load(sys.stdin); assert d["threads"]>=1 and "gl_error" in d, d' || fail "info --json"
fi
"$SQ" scenes | grep -q terrain-flight || fail "scenes lists no terrain-flight"
"$SQ" scene show terrain-flight > tf.yaml || fail "scene show"
"$SQ" simulate tf.yaml --frames 2 --quiet || fail "the shown preset does not load back"
"$SQ" params output | grep -q "fps" || fail "params output"
"$SQ" params world | grep -q "terrain.kind" || fail "params world"
rm -f info.txt tf.yaml
finish
