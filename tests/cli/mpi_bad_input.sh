#!/bin/bash
# label: unit
# requires: mpi snowdrift
# Under mpirun a failure ends every rank with one message (printed once, by rank 0) and the
# usual exit code, and nothing is written; no rank is left waiting (the test's timeout):
#  - bad input every rank sees (a value out of range);
#  - a lattice too thin for the ranks (the decomposition's own rule);
#  - checkpoints (not supported for a split run);
#  - an output only rank 0 checks (the fields directory does not exist): rank 0 fails, the
#    other ranks were ready to step and must stop too.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
read -r -a MPI <<< "${SQ_MPIEXEC:?SQ_MPIEXEC is set by tests/CMakeLists.txt}"
export OMP_NUM_THREADS=1
# mpirun -q: Open MPI's own lines about the non-zero exit are left out
SQ_REAL="$SQ"
run_np() { local np="$1"; shift; timeout 120 "${MPI[@]}" -q -np "$np" "$SQ_REAL" "$@"; }
check() {
    local np="$1" code="$2" pat="$3"
    shift 3
    local before after rc err
    before=$(snapshot "$T")
    run_np "$np" "$@" > "$T/.out" 2> "$T/.err"
    rc=$?
    err=$(mpi_own_lines < "$T/.err")
    rm -f "$T/.out" "$T/.err"
    after=$(snapshot "$T")
    [ "$rc" = "$code" ] || fail "-np $np squall $*: exit $rc, expected $code (stderr: $err)"
    [ "$(printf '%s\n' "$err" | grep -c .)" = 1 ] || fail "-np $np squall $*: stderr is not one line: $err"
    printf '%s' "$err" | grep -Eq -- "$pat" || fail "-np $np squall $*: '$err' does not match '$pat'"
    [ "$before" = "$after" ] || fail "-np $np squall $*: files changed"
}
check 2 2 "layers.snow.wind.speed_mps = -3 m/s" \
    simulate village-snowdrift --frames 2 --quiet --set layers.snow.wind.speed_mps=-3
check 4 2 "cannot be split over 4 ranks.*at most 3 ranks" \
    simulate village-snowdrift --frames 2 --quiet --set layers.snow.domain.nz=6
check 2 2 "checkpoints of a run split over 2 ranks" \
    simulate village-snowdrift --frames 2 --quiet --checkpoint-every 0.05
check 2 2 "no/such/dir" \
    simulate village-snowdrift --frames 2 --quiet --fields no/such/dir/f
exit $fails
