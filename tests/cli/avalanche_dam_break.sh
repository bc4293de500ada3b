#!/bin/bash
# label: physics
# `squall validate dam-break` (the avalanche's SPH solver on the classic dam break): the CSV is
# well formed (header, 8 numeric columns, T = t sqrt(2g/a) and Z = z/a consistent with the t
# and front columns, T increasing, Z never falling by more than one spacing (a thin tip thinning below half
# the rest density), the particle count constant, the front
# sampled every 0.005 s) and the surge front holds the bands of issue 16 against Martin &
# Moyce (1952), at a small resolution (10 particles across the column, 1200 particles):
#   - position: |Z - Z_MM| / Z_MM <= 15 % at every row with 0.8 <= T <= 4 (their points end at
#     T = 3.33), with T = 0 at the release: no time origin fitted;
#   - front speed: the least-squares slope dZ/dT of the rows in 2 <= T <= 3.33 within 10 % of
#     the slope of the experiment's points in that range;
#   - the cause of the remaining lead (a test that could fail): the error is a delay, not a
#     speed error — delaying the simulated clock by one constant dT (scanned here, 0 ... 0.6)
#     leaves at most 5 % at every row, with dT between 0.1 and 0.3 (5-16 ms at a = 2.25 in):
#     the experiment's release took that long (docs/validation.md: the same delay, 0.17-0.23,
#     at 10 to 100 particles across, while the speed stays within 4 %);
#   - Ritter's frictionless front Z <= 1 + 2T bounds every row.
# Reference: J. C. Martin, W. J. Moyce, "An experimental study of the collapse of liquid columns
# on a rigid horizontal plane", Phil. Trans. R. Soc. Lond. A 244 (1952) 312-324, the n^2 = 2
# column of width a = 2.25 in (their surge-front stations every 1/2 in). Points used here,
# typed in independently of the copy inside the validate command: (T, Z) = (0.41, 1.11)
# (0.84, 1.22) (1.19, 1.44) (1.43, 1.67) (1.63, 1.89) (1.83, 2.11) (1.98, 2.33) (2.20, 2.56)
# (2.32, 2.78) (2.51, 3.00) (2.65, 3.22) (2.83, 3.44) (2.98, 3.67) (3.11, 3.89) (3.33, 4.11).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" validate dam-break --particles 10 --threads 1 > db.csv 2> err.txt \
    || fail "validate dam-break exited $?: $(cat err.txt)"
grep -q "^dam-break: a = 0.05715 m, dx = 0.005715 m (10 across), 1200 particles, gate 0 m/s" \
    err.txt || fail "summary line missing: $(cat err.txt)"
[ "$(head -1 db.csv)" = "T,Z,Z_martin_moyce_1952,t_s,front_m,max_speed_mps,particles,substeps" ] \
    || fail "header: $(head -1 db.csv)"
awk -F, -v a=0.05715 '
function mm(T,   i, f) {
    if (T < mt[1] || T > mt[n]) return -1
    for (i = 2; i <= n; i++) if (T <= mt[i]) { f = (T - mt[i-1]) / (mt[i] - mt[i-1]); return mz[i-1] + f * (mz[i] - mz[i-1]) }
    return -1
}
function slope(x, y, k,   i, sx, sy, sxx, sxy) {
    for (i = 1; i <= k; i++) { sx += x[i]; sy += y[i]; sxx += x[i] * x[i]; sxy += x[i] * y[i] }
    return (k * sxy - sx * sy) / (k * sxx - sx * sx)
}
BEGIN {
    split("0.41 0.84 1.19 1.43 1.63 1.83 1.98 2.20 2.32 2.51 2.65 2.83 2.98 3.11 3.33", mt, " ")
    n = split("1.11 1.22 1.44 1.67 1.89 2.11 2.33 2.56 2.78 3.00 3.22 3.44 3.67 3.89 4.11", mz, " ")
    s = sqrt(2 * 9.81 / a); bad = 0; rows = 0; m = 0; nf = 0
}
NR == 1 { next }
{
    rows++
    if (NF != 8) { print "row " NR ": " NF " columns"; bad++ }
    for (k = 1; k <= 8; k++) if (k != 3 && $k !~ /^-?[0-9]+(\.[0-9]+)?$/) { print "row " NR " column " k ": " $k; bad++ }
    if (($1 - $4 * s)^2 > 1e-6) { print "row " NR ": T " $1 " != t sqrt(2g/a) = " $4 * s; bad++ }
    if (($2 - $5 / a)^2 > 1e-6) { print "row " NR ": Z " $2 " != front/a = " $5 / a; bad++ }
    if (rows == 1 && ($1 != 0 || $2 != 1)) { print "first row is not T = 0, Z = 1"; bad++ }
    if (rows > 1 && ($4 - pt - 0.005)^2 > 1e-10) { print "row " NR ": sampled " $4 - pt " s after the previous"; bad++ }
    if ($2 > 1 + 2 * $1 + 1e-9) { print "row " NR ": Z beyond the Ritter front 1 + 2T"; bad++ }
    if (rows == 1) np = $7
    if ($7 != np) { print "row " NR ": particle count changed"; bad++ }
    if (rows > 1 && $1 <= pT) { print "row " NR ": T not increasing"; bad++ }
    if (rows > 1 && $2 < pZ - 0.1 - 1e-9) { print "row " NR ": Z fell by more than one spacing (0.1)"; bad++ }
    T[rows] = $1; Z[rows] = $2
    if ($1 >= 0.8 && (e = mm($1)) > 0) {
        d = ($2 - e) / e; m++
        if (d > worst) { worst = d; wT = $1 }
        if (-d > worst) { worst = -d; wT = $1 }
        sum += (d < 0 ? -d : d)
        if (d > 0.15 || d < -0.15) { printf "T = %s: Z = %s vs Martin & Moyce %.3f (%+.1f %%, band 15 %%)\n", $1, $2, e, 100 * d; bad++ }
    }
    if ($1 >= 2 && $1 <= 3.33) { nf++; fT[nf] = $1; fZ[nf] = $2 }
    pT = $1; pZ = $2; pt = $4
}
END {
    if (rows < 40 || m < 20) { print "too few rows: " rows " (" m " in 0.8 <= T <= 3.33)"; bad++ }
    for (i = 1; i <= n; i++) if (mt[i] >= 1.98 && mt[i] <= fT[nf] + 1e-9) { ne++; eT[ne] = mt[i]; eZ[ne] = mz[i] }
    v = slope(fT, fZ, nf); vm = slope(eT, eZ, ne)
    # the best constant delay of the simulated clock
    bd = 0; bw = 1e9
    for (k = 0; k <= 120; k++) {
        dT = 0.005 * k; w = 0; c = 0
        for (i = 1; i <= rows; i++) if (T[i] + dT >= 0.8 && (e = mm(T[i] + dT)) > 0) { c++; q = (Z[i] - e) / e; if (q < 0) q = -q; if (q > w) w = q }
        if (c >= m / 2 && w < bw) { bw = w; bd = dT }
    }
    printf "front: |Z - Z_MM|/Z_MM mean %.1f %%, max %.1f %% at T = %.2f over %d rows; dZ/dT %.3f vs Martin & Moyce %.3f (%+.1f %%); best delay %.3f in T leaves max %.1f %%\n", 100 * sum / m, 100 * worst, wT, m, v, vm, 100 * (v / vm - 1), bd, 100 * bw
    if (v < 0.9 * vm || v > 1.1 * vm) { print "front speed " v " not within 10 % of " vm; bad++ }
    if (bd < 0.1 || bd > 0.3 || bw > 0.05) { print "the error is not a constant delay of 0.1-0.3 in T: best " bd " leaves " 100 * bw " %"; bad++ }
    exit bad > 0
}' db.csv > check.txt || fail "dam-break CSV: $(cat check.txt)"
cat check.txt
# A candidate that is not the cause: the experiment's observers missing the thin tip. Counted as
# the farthest column where the surge is at least water's capillary length sqrt(sigma/(rho g))
# = 2.7 mm deep (a thinner tip is what surface tension and the contact line reshape; 25 across,
# a layer is 2.3 mm), the front still leads by more than 5 % on average (measured 8.6 % at 25
# and 50 across against 10.9-11.1 % for the farthest particle; docs/validation.md): the thin
# tip explains at most a quarter of the lead.
"$SQ" validate dam-break --particles 25 --front-depth 0.0027 --threads 1 > db25.csv 2> err25.txt \
    || fail "validate dam-break --front-depth exited $?: $(cat err25.txt)"
grep -q "front depth 0.0027 m: " err25.txt || fail "front depth missing: $(cat err25.txt)"
mean=$(sed -n 's/.*over 0.8 <= T <= 4: mean \([0-9.]*\) %.*/\1/p' err25.txt)
[ -n "$mean" ] || fail "no mean error in: $(cat err25.txt)"
awk -v m="$mean" 'BEGIN { exit !(m > 5.0) }' \
    || fail "with the front 2.7 mm deep the mean lead is $mean % (<= 5 %): the thin tip would explain it"
echo "front at 2.7 mm depth, 25 across: mean lead $mean %"
# The release model: with no gate speed and no gate acceleration the release is instantaneous
# and the output is the default's, bit for bit.
"$SQ" validate dam-break --particles 10 --gate-speed 0 --gate-accel 0 --threads 1 > db0.csv \
    2> err0.txt || fail "validate dam-break --gate-speed 0 --gate-accel 0 exited $?: $(cat err0.txt)"
cmp -s db.csv db0.csv || fail "--gate-speed 0 --gate-accel 0 changed the CSV"
cmp -s err.txt err0.txt || fail "--gate-speed 0 --gate-accel 0 changed the summary: $(cat err0.txt)"
# A modelled release that is not the experiment's: a gate lifted from rest at g (the fastest a
# gate pulled by a falling weight can go) opens the column in its free-fall time sqrt(2 h0 / g)
# = 0.15 s, the slowest release Lauber & Hager (1998) count as instantaneous. It holds the upper
# column back so long that the front over 2 <= T <= 3.33 runs more than 10 % slower than the
# experiment's (measured -22.7 % at 25 across, -24.4 % at 50; docs/validation.md), while a front
# that is not held (the instantaneous release) runs within 1 % of it: Martin & Moyce's column was
# free much sooner than a weight-lifted gate frees it.
"$SQ" validate dam-break --particles 25 --gate-accel 9.81 --threads 1 > dbg.csv 2> errg.txt \
    || fail "validate dam-break --gate-accel exited $?: $(cat errg.txt)"
grep -q "gate 0 m/s (from rest at 9.81 m/s^2)" errg.txt || fail "gate missing: $(cat errg.txt)"
speed=$(sed -n 's/.*vs Martin & Moyce [0-9.]* (\([-+0-9.]*\) %).*/\1/p' errg.txt)
[ -n "$speed" ] || fail "no front speed in: $(cat errg.txt)"
awk -v v="$speed" 'BEGIN { exit !(v < -10.0) }' \
    || fail "a gate opening in the free-fall time gives a front speed $speed % off (not < -10 %)"
echo "gate from rest at g, 25 across: front speed $speed % against the experiment's"
finish
