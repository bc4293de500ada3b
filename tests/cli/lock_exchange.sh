#!/bin/bash
# label: physics
# `squall validate lock-exchange` (issue 12: the carrier flow of the sandstorm): a full-depth
# lock-exchange gravity current on the grid solver, H = 1000 m, dT = 3 K on 300 K, so
# g' = 9.81 * 3 / 300 = 0.0981 m/s^2 and sqrt(g' H) = 9.905 m/s (computed here, not read from
# the command). At 32 cells over the depth (256 x 4 x 32, ~20 s):
#   - the CSV is well formed: header t_s,front_m, time increasing from 0, the front starting at
#     the lock (0) and never moving back by more than one cell (31.25 m);
#   - the front speed, fitted here by least squares to the rows with the front between 0.5 H
#     and 3 H, gives Fr = U / sqrt(g' H) within 10 % of 1/2: Benjamin (1968, J. Fluid Mech. 31,
#     209-248), the energy-conserving current of half the depth; full-depth lock-exchange
#     experiments (Shin, Dalziel & Linden 2004, J. Fluid Mech. 521, 1-34).
# The --json summary (at 16 cells, 4 s) names the fitted speed and Froude number consistently
# (froude = front_speed / 9.905 within 0.1 %). With the Smagorinsky-Lilly subgrid closure
# (--closure smagorinsky, 32 cells) and with Deardorff's TKE closure (--closure tke) the current
# keeps Fr within 10 % of 1/2 as well.
# A three-dimensional current (--spanwise 0.05 --width 8: the cold side's deficit varying across
# the slab by 5 %, as the haboob's coldpool.spanwise_variation does) keeps Fr within 10 % of
# 1/2 at 32 cells. The sandstorm's helicity-adaptive vorticity confinement (--confinement 0.15,
# solver.confinement) is zero where the flow does not vary across the slab (the helicity u.w
# vanishes: u in the x-z plane, w along y): the 2-D current's front speed with it is the one
# without it to 0.2 % (24 cells).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" validate lock-exchange --n 32 > le.csv 2> err.txt \
    || fail "validate lock-exchange exited $?: $(cat err.txt)"
[ "$(head -1 le.csv)" = "t_s,front_m" ] || fail "header: $(head -1 le.csv)"
res=$(awk -F, '
NR == 1 { next }
{
    rows++
    if (NF != 2 || $1 !~ /^[0-9]+(\.[0-9]+)?$/ || $2 !~ /^-?[0-9]+(\.[0-9]+)?$/) { print "row " NR ": " $0; bad++ }
    if (rows == 1 && ($1 != 0 || $2 != 0)) { print "first row is not t = 0 at the lock: " $0; bad++ }
    if (rows > 1 && $1 <= pt) { print "row " NR ": time not increasing"; bad++ }
    if (rows > 1 && $2 < pf - 31.25) { print "row " NR ": front moved back " pf - $2 " m"; bad++ }
    if ($2 >= 500 && $2 <= 3000) { k++; sx += $1; sy += $2; sxx += $1 * $1; sxy += $1 * $2 }
    pt = $1; pf = $2
}
END {
    if (k < 10) { print "only " k " rows in the fit window"; bad++ }
    else { U = (k * sxy - sx * sy) / (k * sxx - sx * sx); Fr = U / 9.905
           printf "FR %.4f U %.4f rows %d\n", Fr, U, k
           if (Fr < 0.45 || Fr > 0.55) { print "Fr " Fr " outside 0.5 +- 10 %"; bad++ } }
    if (bad) print "BAD " bad
}' le.csv)
echo "$res"
echo "$res" | grep -q "^BAD" && fail "lock-exchange CSV: $res"
echo "$res" | grep -q "^FR " || fail "no fit: $res"
"$SQ" validate lock-exchange --n 16 --json > le.json 2> err.txt \
    || fail "validate lock-exchange --json exited $?: $(cat err.txt)"
python3 - le.json <<'PY' || fail "json summary inconsistent: $(cat le.json)"
import json, sys
j = json.load(open(sys.argv[1]))
for k in ("front_speed_mps", "froude", "froude_theory", "relative_error", "within_10_percent"):
    assert k in j, k
assert abs(j["froude"] - j["front_speed_mps"] / 9.905) < 1e-3 * j["froude"], j
assert j["froude_theory"] == 0.5 and abs(j["relative_error"] - (j["froude"] / 0.5 - 1)) < 1e-5
PY
"$SQ" validate lock-exchange --n 32 --closure smagorinsky --json > les.json 2> err.txt \
    || fail "validate lock-exchange --closure smagorinsky exited $?: $(cat err.txt)"
python3 - les.json <<'PY' || fail "subgrid closure: $(cat les.json)"
import json, sys
j = json.load(open(sys.argv[1]))
assert j["closure"] == "smagorinsky", j
fr = j["front_speed_mps"] / 9.905
print("subgrid closure: Fr %.4f" % fr)
assert 0.45 <= fr <= 0.55, fr
PY
"$SQ" validate lock-exchange --n 16 --closure les > /dev/null 2> err.txt
[ $? -eq 2 ] && grep -q "closure 'les'" err.txt || fail "bad --closure: $(cat err.txt)"
"$SQ" validate lock-exchange --n 32 --closure tke --json > let.json 2> err.txt \
    || fail "validate lock-exchange --closure tke exited $?: $(cat err.txt)"
python3 - let.json <<'PY' || fail "TKE closure: $(cat let.json)"
import json, sys
j = json.load(open(sys.argv[1]))
assert j["closure"] == "tke", j
fr = j["front_speed_mps"] / 9.905
print("TKE closure: Fr %.4f" % fr)
assert 0.45 <= fr <= 0.55, fr
PY
"$SQ" validate lock-exchange --n 32 --width 8 --spanwise 0.05 --json > le3.json 2> err.txt \
    || fail "validate lock-exchange --spanwise exited $?: $(cat err.txt)"
python3 - le3.json <<'PY' || fail "3-D current: $(cat le3.json)"
import json, sys
j = json.load(open(sys.argv[1]))
assert j["ny"] == 8 and j["spanwise"] == 0.05, j
fr = j["front_speed_mps"] / 9.905
print("3-D current: Fr %.4f" % fr)
assert 0.45 <= fr <= 0.55, fr
PY
"$SQ" validate lock-exchange --n 24 --json > le0.json 2> err.txt \
    || fail "validate lock-exchange --n 24 exited $?: $(cat err.txt)"
"$SQ" validate lock-exchange --n 24 --confinement 0.15 --json > lec.json 2> err.txt \
    || fail "validate lock-exchange --confinement exited $?: $(cat err.txt)"
python3 - le0.json lec.json <<'PY' || fail "confinement in 2-D flow: $(cat le0.json lec.json)"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert a["confinement"] == 0 and b["confinement"] == 0.15 and not b["plain_confinement"], (a, b)
rel = abs(b["front_speed_mps"] / a["front_speed_mps"] - 1)
print("helicity-adaptive confinement in 2-D flow: front speed %.4f vs %.4f m/s (%.2g)"
      % (b["front_speed_mps"], a["front_speed_mps"], rel))
assert rel < 2e-3, rel
PY
"$SQ" validate lock-exchange --n 16 --confinement 5 > /dev/null 2> err.txt
[ $? -eq 2 ] && grep -q -- "--confinement 5" err.txt || fail "bad --confinement: $(cat err.txt)"
finish
