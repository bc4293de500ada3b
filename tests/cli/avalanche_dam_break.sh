#!/bin/bash
# label: physics
# `squall validate dam-break` (the avalanche's SPH solver on the classic dam break, issue 6
# item 6): the CSV is well formed (header, 8 numeric columns, T = t sqrt(2g/a) and Z = z/a
# consistent with the t and front columns, T increasing, Z non-decreasing, the particle count
# constant) and the surge front lies in a stated band around Martin & Moyce (1952).
#
# Reference: J. C. Martin, W. J. Moyce, "An experimental study of the collapse of liquid columns
# on a rigid horizontal plane", Phil. Trans. R. Soc. Lond. A 244 (1952) 312-324, the n^2 = 2
# column of width a = 2.25 in (their surge-front stations every 1/2 in, i.e. steps of 0.222 in
# Z). Points used here, (T, Z): (0.84, 1.22) (1.19, 1.44) (1.43, 1.67) (1.63, 1.89)
# (1.83, 2.11) (1.98, 2.33) (2.20, 2.56) (2.32, 2.78) (2.51, 3.00) (2.65, 3.22) (2.83, 3.44)
# (2.98, 3.67) — typed in here independently of the copy inside the validate command.
# Band: the simulated front may lead the experiment by up to 0.4 in Z and lag it by at most
# 0.1 over 1 <= T <= 3. Numerical fronts lead the measurement because the experiment's gate
# needed time to open (the SPH/MPS literature, e.g. Koshizuka & Oka 1996, and Colagrossi &
# Landrini 2003, show the same lead); measured here 0.17 mean, 0.23 max (a = 0.1 m, dx = 1 cm).
# Speed: the mean front speed dZ/dT over 1.5 <= T <= 3 within 25 % of the experiment's
# (M&M: (3.67 - 1.77) / (2.98 - 1.50) ~ 1.3; measured 1.20 vs 1.30), and the front behind the
# frictionless shallow-water (Ritter 1892) front z = a + 2 sqrt(g h0) t, h0 = 2a, i.e.
# Z <= 1 + 2T, also over every output interval up to T = 3 (dZ/dT <= 2; later the thin tip
# of the surge, still above half the rest density, can jump ahead of a frictionless front).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
"$SQ" validate dam-break --a 0.1 --spacing 0.01 --t-end 0.25 --every 0.01 --threads 1 \
    > db.csv 2> err.txt || fail "validate dam-break exited $?: $(cat err.txt)"
grep -q "^dam-break: a = 0.1 m, dx = 0.01 m, 1200 particles: |Z - Z_MM| over 1 <= T <= 3: mean" \
    err.txt || fail "summary line missing: $(cat err.txt)"
[ "$(head -1 db.csv)" = "T,Z,Z_martin_moyce_1952,t_s,front_m,max_speed_mps,particles,substeps" ] \
    || fail "header: $(head -1 db.csv)"
awk -F, -v a=0.1 '
function mm(T,   i, f) {
    for (i = 2; i <= n; i++) if (T <= mt[i]) { f = (T - mt[i-1]) / (mt[i] - mt[i-1]); return mz[i-1] + f * (mz[i] - mz[i-1]) }
    return -1
}
BEGIN {
    split("0.84 1.19 1.43 1.63 1.83 1.98 2.20 2.32 2.51 2.65 2.83 2.98", mt, " ")
    n = split("1.22 1.44 1.67 1.89 2.11 2.33 2.56 2.78 3.00 3.22 3.44 3.67", mz, " ")
    s = sqrt(2 * 9.81 / a); bad = 0; rows = 0; lead = 0; lag = 0
}
NR == 1 { next }
{
    rows++
    if (NF != 8) { print "row " NR ": " NF " columns"; bad++ }
    for (k = 1; k <= 8; k++) if (k != 3 && $k !~ /^-?[0-9]+(\.[0-9]+)?$/) { print "row " NR " column " k ": " $k; bad++ }
    if ($3 != "" && $3 !~ /^[0-9]+\.[0-9]+$/) { print "row " NR ": Z_MM " $3; bad++ }
    if (($1 - $4 * s)^2 > 1e-6) { print "row " NR ": T " $1 " != t sqrt(2g/a) = " $4 * s; bad++ }
    if (($2 - $5 / a)^2 > 1e-6) { print "row " NR ": Z " $2 " != front/a = " $5 / a; bad++ }
    if (rows == 1 && ($1 != 0 || $2 != 1)) { print "first row is not T = 0, Z = 1"; bad++ }
    if ($2 > 1 + 2 * $1 + 1e-9) { print "row " NR ": Z beyond the Ritter front 1 + 2T"; bad++ }
    if (rows == 1) np = $7
    if ($7 != np) { print "row " NR ": particle count changed"; bad++ }
    if (rows > 1 && $1 <= pT) { print "row " NR ": T not increasing"; bad++ }
    if (rows > 1 && $2 < pZ - 1e-9) { print "row " NR ": Z decreasing"; bad++ }
    if (rows > 1 && $1 <= 3.0 && ($2 - pZ) / ($1 - pT) > 2.0) { print "row " NR ": dZ/dT = " ($2 - pZ) / ($1 - pT) " above the Ritter bound 2"; bad++ }
    if ($1 >= 1 && $1 <= 2.98) {
        d = $2 - mm($1); m++
        if (d > lead) lead = d
        if (-d > lag) lag = -d
        if (d > 0.4 || d < -0.1) { print "T = " $1 ": Z = " $2 " vs Martin & Moyce " mm($1) " (band -0.1 .. +0.4)"; bad++ }
    }
    if ($1 >= 1.5 && T0 == "") { T0 = $1; Z0 = $2 }
    if ($1 <= 3.0) { T1 = $1; Z1 = $2 }
    pT = $1; pZ = $2
}
END {
    if (rows < 20 || m < 10) { print "too few rows: " rows " (" m " in 1 <= T <= 3)"; bad++ }
    v = (Z1 - Z0) / (T1 - T0); vm = (mm(T1) - mm(T0)) / (T1 - T0)
    printf "front: largest lead %.3f, largest lag %.3f over %d rows; dZ/dT %.3f vs Martin & Moyce %.3f\n", lead, lag, m, v, vm
    if (v < 0.75 * vm || v > 1.25 * vm) { print "front speed " v " not within 25 % of " vm; bad++ }
    exit bad > 0
}' db.csv > check.txt || fail "dam-break CSV: $(cat check.txt)"
cat check.txt
finish
