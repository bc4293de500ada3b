#!/bin/bash
# label: smoke
# squall visibility: JSON output with finite positive extinction, mass extinction and
# visibility; bad input (a concentration without a unit, sigma_g <= 1) exits 2 naming the option.
set -u
squall="$1"
fail=0
err() { echo "FAIL: $*" >&2; fail=1; }

out=$("$squall" visibility --concentration 5000ug/m3 --median-radius 2um --sigma-g 2 --json)
rc=$?
[ "$rc" -eq 0 ] || err "visibility --json exited $rc"
echo "$out"
check_json() {
    if command -v python3 >/dev/null 2>&1; then
        python3 - "$1" <<'PY'
import json, math, sys
d = json.loads(sys.argv[1])
for k in ("extinction_per_m", "mass_extinction_m2_per_g", "visibility_m"):
    v = d[k]
    assert isinstance(v, (int, float)) and math.isfinite(v) and v > 0, (k, v)
# Koschmieder with the default 5 % threshold, and beta = C k
assert abs(d["visibility_m"] * d["extinction_per_m"] - 2.995732) < 1e-4, d
assert abs(d["extinction_per_m"] - 5e-6 * d["mass_extinction_m2_per_g"] * 1e3) < 1e-5 * d["extinction_per_m"], d
PY
    else
        for k in extinction_per_m mass_extinction_m2_per_g visibility_m; do
            echo "$1" | grep -Eq "\"$k\": [0-9.]+(e[-+]?[0-9]+)?[,}]" || return 1
        done
    fi
}
check_json "$out" || err "JSON output invalid or values not finite and positive: $out"

expect_usage_error() {
    local needle="$1"
    shift
    local msg
    msg=$("$squall" visibility "$@" 2>&1 >/dev/null)
    local rc=$?
    [ "$rc" -eq 2 ] || err "visibility $* exited $rc, expected 2"
    echo "$msg" | grep -q -- "$needle" || err "visibility $*: message '$msg' does not name $needle"
    [ "$(echo "$msg" | wc -l)" -eq 1 ] || err "visibility $*: message is not one line: $msg"
    echo "$msg" | grep -q '^squall: ' || err "visibility $*: message does not start with 'squall: '"
}
expect_usage_error --concentration --concentration 5000 --median-radius 2um --sigma-g 2
expect_usage_error --sigma-g --concentration 5000ug/m3 --median-radius 2um --sigma-g 0.9
expect_usage_error --median-radius --concentration 5000ug/m3 --median-radius -2um
expect_usage_error --n-imag --concentration 5000ug/m3 --n-imag -0.003
expect_usage_error --wavelength --concentration 5000ug/m3 --wavelength 0nm

"$squall" visibility --help | grep -q "ug/m3" || err "--help does not list the units"
exit $fail
