#!/bin/bash
# label: unit
# requires: mpi
# `squall bench project` under mpirun: the projection split in slabs takes as many CG iterations
# as one rank (its coarse levels are the whole grid's), reports every rank with the bytes it sent
# (> 0: the halo planes and the level-1 sums travelled), prints one JSON line (rank 0 only); a
# grid too thin for the ranks ends every rank with one line and exit 2.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
read -r -a MPI <<< "${SQ_MPIEXEC:?SQ_MPIEXEC is set by tests/CMakeLists.txt}"
export OMP_NUM_THREADS=1
run_np() { local np="$1"; shift; timeout 120 "${MPI[@]}" -q -np "$np" "$SQ" "$@"; }
field() { sed -n "s/.*\"$1\": \([0-9.e+-]*\).*/\1/p"; }
one=$(run_np 1 bench project --size 32x16x16 --reps 2 --threads 1) || fail "np 1 failed"
two=$(run_np 2 bench project --size 32x16x16 --reps 2 --threads 1) || fail "np 2 failed"
[ "$(printf '%s\n' "$two" | grep -c '^{')" = 1 ] || fail "np 2: not one JSON line: $two"
it1=$(printf '%s' "$one" | field cg_iterations)
it2=$(printf '%s' "$two" | field cg_iterations)
[ -n "$it1" ] && [ "$it1" = "$it2" ] || fail "CG iterations: one rank $it1, two ranks $it2"
printf '%s' "$two" | grep -q '"ranks": 2' || fail "np 2: ranks is not 2: $two"
[ "$(printf '%s' "$two" | grep -o '"bytes_sent_per_project": [0-9]*' | awk '$2 > 0' | wc -l)" = 2 ] ||
    fail "np 2: not two ranks with bytes sent: $two"
err=$(run_np 4 bench project --size 12x8x8 --reps 1 --threads 1 2>&1 >/dev/null)
rc=$?
err=$(printf '%s\n' "$err" | mpi_own_lines)
[ "$rc" = 2 ] || fail "np 4 on 12 cells: exit $rc, expected 2 ($err)"
[ "$(printf '%s\n' "$err" | grep -c .)" = 1 ] || fail "np 4 on 12 cells: not one line: $err"
printf '%s' "$err" | grep -q "cannot be split over 4 ranks" || fail "np 4 on 12 cells: $err"
exit $fails
