# lib.sh — helpers for the CLI tests. Each test script sources this, gets the squall binary as
# $1, and runs in a fresh temporary directory that is removed afterwards.
set -u
SQ="$1"
SRC="${SQ_SOURCE_DIR:?}"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
cd "$T"
fails=0

fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }

# snapshot DIR: names, sizes and checksums of every file (to prove nothing changed)
snapshot() { (cd "$1" && find . -type f -print0 | sort -z | xargs -0 -r sha256sum) ; }

# expect CODE PATTERN -- ARGS...: runs squall ARGS, checks the exit code, that stderr is one
# line containing PATTERN (grep -E), and that the working directory is unchanged.
expect() {
    local code="$1" pat="$2"
    shift 3
    local before after
    before=$(snapshot "$T")
    "$SQ" "$@" >"$T/.stdout" 2>"$T/.stderr"
    local rc=$?
    local err
    err=$(cat "$T/.stderr")
    rm -f "$T/.stdout" "$T/.stderr"
    after=$(snapshot "$T")
    [ "$rc" = "$code" ] || fail "squall $*: exit $rc, expected $code (stderr: $err)"
    [ "$(printf '%s\n' "$err" | grep -c .)" = 1 ] || fail "squall $*: stderr is not one line: $err"
    printf '%s' "$err" | grep -Eq -- "$pat" || fail "squall $*: stderr '$err' does not match '$pat'"
    [ "$before" = "$after" ] || fail "squall $*: files changed: $(diff <(echo "$before") <(echo "$after"))"
}

# A small scene that renders fast.
tiny_scene() {
    cat > "$1" <<YAML
name: tiny
world:
  terrain: {kind: hills, size_m: [400, 400], resolution: [33, 33], relief_m: 20}
camera: {position: [-150, -150, 60], target: [0, 0, 0]}
output: {width: 64, height: 48, fps: 4, frames: 2, video: out.mp4}
YAML
}

# png_file PATH W H BITDEPTH COLORTYPE [nodata]: writes a valid PNG (zeros) or, with nodata,
# only the header (for size checks that must happen before decoding).
png_file() {
    python3 - "$@" <<'PY'
import struct, sys, zlib
path, w, h, depth, ctype = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
nodata = len(sys.argv) > 6
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
ch = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
row = 1 + w * ch * depth // 8
data = zlib.compress(b"\0" * 16) if nodata else zlib.compress(b"\0" * (row * h))
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, 0))
png += chunk(b"IDAT", data)
png += chunk(b"IEND", b"")
open(path, "wb").write(png)
PY
}

finish() {
    if [ "$fails" != 0 ]; then echo "$fails check(s) failed" >&2; exit 1; fi
    echo ok
}

# has_feature NAME: the squall under test was built with NAME (as `squall info` lists features)
has_feature() { "$SQ" info 2>/dev/null | grep -Eq "^features:.* $1( |$)"; }

# mpi_own_lines: stderr of an mpirun without the line libevent (inside Open MPI 4.1's runtime, not
# squall) sometimes prints when a rank's socket closes while its exit is being handled ("[warn]
# Epoll MOD(1) on fd 26 failed. ... Bad file descriptor"; seen in 1 of ~55 failing runs here):
# the tests count squall's own lines.
mpi_own_lines() { grep -v '^\[warn\] Epoll [A-Z]*([0-9]*) on fd [0-9]* failed\.' || true; }
