#!/bin/bash
# label: physics
# requires: mpi snowdrift
# `mpirun -np N squall simulate village-snowdrift` splits the wind lattice over N ranks (slabs
# along z, docs/mpi.md) and must give the one-rank answer bit for bit: the field files (VTK,
# every frame: wind, snow depth, airborne snow) and the metrics rows of 1, 2 and 4 ranks (4
# oversubscribed on a 2-core machine, one thread each) are byte-identical, written once (by
# rank 0), and the snow budget closes exactly in flakes at every frame: fallen = airborne +
# deposited + left. Snowfall and erosion are time-lapsed so flakes travel, land and lift within
# the few frames.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
read -r -a MPI <<< "${SQ_MPIEXEC:?SQ_MPIEXEC is set by tests/CMakeLists.txt}"
export OMP_NUM_THREADS=1
common=(simulate village-snowdrift --frames 3 --threads 1 --quiet --set output.fields_format=vtk
        --set output.fields_every=1
        --set layers.snow.snow.speedup=45000 --set layers.snow.draw.flakes=0)
"$SQ" "${common[@]}" --fields one --metrics one.csv 2> err.txt || fail "1 rank: exit $?: $(cat err.txt)"
ls one_* > /dev/null 2>&1 || fail "1 rank wrote no field files"
for np in 2 4; do
    timeout 600 "${MPI[@]}" -np $np "$SQ" "${common[@]}" --fields r$np --metrics r$np.csv \
        2> err.txt || fail "$np ranks: exit $?: $(cat err.txt)"
    for f in one_*; do
        g="r$np${f#one}"
        [ -f "$g" ] || { fail "$np ranks did not write $g"; continue; }
        case "$f" in
        *.pvd) # the index names the files: compare with the one-rank names put in
            sed "s/\"r${np}_/\"one_/g" "$g" | cmp -s "$f" - || fail "$np ranks: index $g differs" ;;
        *) cmp -s "$f" "$g" || fail "$np ranks: $g differs from the one-rank $f" ;;
        esac
    done
    [ "$(ls r${np}_* | wc -l)" = "$(ls one_* | wc -l)" ] || fail "$np ranks: other files: $(ls r${np}_*)"
    cmp -s one.csv r$np.csv || fail "$np ranks: metrics differ: $(diff one.csv r$np.csv | head -5)"
done
# drifts: snowfall time-lapsed 3e6 times fills cells from the first frame, so cells turn
# snow-solid (and eroded ones fluid) in every slab and next to the slab faces, and the wind
# lattice learns them from the slab that holds them (the cover layer's flakes are off: they
# are only drawn, and at this snowfall they crash a one-rank run as well, a separate bug)
drift=(simulate village-snowdrift --frames 4 --threads 1 --quiet --set output.fields_format=vtk
       --set output.fields_every=3 --set layers.snow.snow.speedup=3000000
       --set layers.snow.draw.flakes=0 --set layers.cover.flakes.count=0)
"$SQ" "${drift[@]}" --fields d1 --metrics d1.csv 2> err.txt || fail "drifts, 1 rank: exit $?: $(cat err.txt)"
python3 - d1.csv > cells.txt 2>&1 <<'PY' || fail "drifts: $(cat cells.txt)"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
cells = [float(r[k]) for r in rows for k in r if k.startswith("snow.snow_cells")]
assert len(cells) == 4 and cells[-1] > 1000, ("too few snow-solid cells to test the coupling", cells)
PY
for np in 2 4; do
    timeout 600 "${MPI[@]}" -np $np "$SQ" "${drift[@]}" --fields d$np --metrics d$np.csv \
        2> err.txt || fail "drifts, $np ranks: exit $?: $(cat err.txt)"
    cmp -s d1.csv d$np.csv || fail "drifts, $np ranks: metrics differ: $(diff d1.csv d$np.csv | head -5)"
    for f in d1_*; do
        case "$f" in *.pvd) continue ;; esac
        cmp -s "$f" "d$np${f#d1}" || fail "drifts, $np ranks: d$np${f#d1} differs from the one-rank $f"
    done
done
# the exact budget, every frame: the metrics are in kg of whole flakes (15 kg each: 150 kg/m3
# snow, 10 flakes per 1 m cell)
python3 - one.csv > budget.txt 2>&1 <<'PY' || fail "budget: $(cat budget.txt)"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert rows, "no metrics rows"
def flakes(r, name):
    keys = [k for k in r if k.startswith(name)]
    assert len(keys) == 1, (name, list(r))
    x = float(r[keys[0]]) / 15.0
    assert abs(x - round(x)) < 1e-6, (name, x)
    return round(x)
deposited = 0
for r in rows:
    fallen, air, dep, left = (flakes(r, "snow.snow_" + k) for k in ("fallen", "airborne",
                                                           "deposited", "left"))
    assert fallen == air + dep + left, (fallen, air, dep, left)
    deposited = max(deposited, dep)
assert deposited > 0, "no flake deposited: the test does not exercise the snow"
PY
exit $fails
