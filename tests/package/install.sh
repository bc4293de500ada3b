#!/bin/bash
# label: package
# requires: sandstorm snowdrift avalanche
# The installed package: `cmake --install` of this build into a temporary prefix puts the
# headers, libsquall.a, libsquall.so, the CMake package and squall.pc there; then every example
# of examples/ is built against the INSTALLED files only — through find_package(Squall) (shared
# and static) and through pkg-config (shared and static) — and run, and its output is checked:
# visibility in metres (finite, > 0), a PGM slice with dust in it, the GL example's two pictures
# (the drawables-only one must differ from the plain backdrop), an avalanche front that moves.
# Each way (find_package, pkg-config) runs all four once and the first with the other library.
set -u
SRC="${SQ_SOURCE_DIR:?}"
BUILD="${SQ_BUILD_DIR:?}"
CMAKE="${SQ_CMAKE:-cmake}"
CC="${SQ_CC:-cc}"
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
P="$W/prefix"
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# A build for this machine's CPU refuses to install unless told (SQ_INSTALL_NATIVE=1).
if grep -q '^SQ_NATIVE:BOOL=ON' "$BUILD/CMakeCache.txt"; then
    if "$CMAKE" --install "$BUILD" --prefix "$W/refused" > "$W/refused.log" 2>&1; then
        fail "a -march=native build installed without SQ_INSTALL_NATIVE=1"
    elif ! grep -q "SQ_NATIVE=OFF" "$W/refused.log"; then
        fail "the refusal does not say what to do: $(cat "$W/refused.log")"
    fi
fi
if ! SQ_INSTALL_NATIVE=1 "$CMAKE" --install "$BUILD" --prefix "$P" > "$W/install.log" 2>&1; then
    cat "$W/install.log"; echo "FAIL: cmake --install"; exit 1
fi
LIBDIR=$(dirname "$(find "$P" -name squall.pc)")/..
for f in include/squall/squall.h include/squall/phenomenon.h bin/squall; do
    [ -e "$P/$f" ] || fail "$f not installed"
done
for f in libsquall.a libsquall.so pkgconfig/squall.pc cmake/Squall/SquallConfig.cmake \
         cmake/Squall/SquallConfigVersion.cmake cmake/Squall/SquallTargets.cmake; do
    [ -e "$LIBDIR/$f" ] || fail "lib/$f not installed"
done
# The shared library exports the public API only (sq_*), never a dependency's symbols.
others=$(nm -D --defined-only "$LIBDIR/libsquall.so" | awk '$2 ~ /[TDBR]/ && $3 !~ /^(sq_|_edata$|_end$|__bss_start$|_init$|_fini$)/ {print $3}' | head -5)
[ -z "$others" ] || fail "libsquall.so exports non-API symbols: $others"

# Runs the examples of directory $1 (label $2) and checks what they print and write: all four,
# or with $3 = quick only the first (each way of linking runs all four once: find_package with
# the shared library, pkg-config with the static one).
run_examples() {
    local d="$1" tag="$2" out
    out=$("$d/sandstorm_visibility" 20 2>&1) || fail "$tag: sandstorm_visibility: $out"
    echo "$out" | awk -v tag="$tag" '$2 == "visibility_min_h0_m" {n++; if (!($3 > 0 && $3 < 1e9 && $4 == "m")) bad++}
        END {if (n < 2 || bad) {print "FAIL: " tag ": visibility lines " n ", bad " bad+0; exit 1}}' || fails=$((fails + 1))
    [ "${3:-}" = quick ] && return
    out=$("$d/dust_slice_pgm" "$W/$tag.pgm" 1 2>&1) || fail "$tag: dust_slice_pgm: $out"
    if [ "$(head -n 3 "$W/$tag.pgm" 2>/dev/null | tr '\n' ' ')" != "P5 32 32 255 " ]; then
        fail "$tag: PGM header"
    elif [ "$(tail -c 1024 "$W/$tag.pgm" | od -An -v -tu1 | awk '{for (i = 1; i <= NF; i++) if ($i > 0) n++} END {print n + 0}')" -lt 20 ]; then
        fail "$tag: the PGM slice has (almost) no dust"
    fi
    if [ -x "$d/snowdrift_gl" ]; then
        out=$("$d/snowdrift_gl" "$W/$tag.ppm" 2>&1) || fail "$tag: snowdrift_gl: $out"
        for f in "$W/$tag.ppm" "$W/$tag.ppm.over.ppm"; do
            [ "$(stat -c %s "$f" 2>/dev/null)" = $((15 + 320 * 180 * 3)) ] || fail "$tag: $f size"
        done
        # backdrop grey (0.35, 0.4, 0.45) * 255 = (89, 102, 115); snow makes some pixels differ
        changed=$(tail -c $((320 * 180 * 3)) "$W/$tag.ppm.over.ppm" | od -An -v -tu1 -w3 |
                  awk '($1 - 89)^2 + ($2 - 102)^2 + ($3 - 115)^2 > 100 {n++} END {print n + 0}')
        [ "$changed" -ge 50 ] || fail "$tag: the snow drawn over the backdrop changed $changed pixels"
    fi
    out=$("$d/avalanche_heightfield" 6 2>&1) || fail "$tag: avalanche_heightfield: $out"
    echo "$out" | awk -v tag="$tag" '$1 ~ /^[0-9.]+$/ {f[n++] = $2}
        END {if (n < 3 || !(f[n-1] > f[0] + 1)) {print "FAIL: " tag ": the front did not move: " f[0] " -> " f[n-1]; exit 1}}' || fails=$((fails + 1))
}

# 1, 2: find_package(Squall), shared and static
for kind in shared static; do
    st=OFF; [ $kind = static ] && st=ON
    if "$CMAKE" -S "$SRC/examples" -B "$W/cmake-$kind" -DCMAKE_C_COMPILER="$CC" \
            -DCMAKE_PREFIX_PATH="$P" -DSQUALL_EXAMPLES_STATIC=$st > "$W/cfg-$kind.log" 2>&1 &&
       "$CMAKE" --build "$W/cmake-$kind" -j2 > "$W/build-$kind.log" 2>&1; then
        run_examples "$W/cmake-$kind" "cmake-$kind" "$([ $kind = static ] && echo quick)"
    else
        cat "$W/cfg-$kind.log" "$W/build-$kind.log" | tail -30; fail "find_package, $kind: build"
    fi
done
# the soname is the ABI version: major.minor before 1.0 (a 0.x minor may break the ABI), then major
ver() { sed -n "s/^#define SQ_VERSION_$1 \([0-9]*\)$/\1/p" "$SRC/include/squall/core.h"; }
soname="libsquall.so.$(ver MAJOR)"
[ "$(ver MAJOR)" = 0 ] && soname="$soname.$(ver MINOR)"
readelf -d "$LIBDIR/libsquall.so" | grep -q "SONAME.*\[$soname\]" ||
    fail "libsquall.so: soname is not $soname: $(readelf -d "$LIBDIR/libsquall.so" | grep SONAME)"
ldd "$W/cmake-shared/sandstorm_visibility" | grep -q "$soname => $P" || fail "cmake-shared: not linked to the installed $soname"
ldd "$W/cmake-static/sandstorm_visibility" | grep -q "libsquall.so" && fail "cmake-static: linked to libsquall.so"

# 3, 4: pkg-config, shared and static (-l:libsquall.a: the archive beside the shared library)
export PKG_CONFIG_PATH="$LIBDIR/pkgconfig"
gl_flags=""
pkg-config --variable=features squall | grep -qw gl && gl_flags=$(pkg-config --cflags --libs egl epoxy)
for kind in shared static; do
    mkdir -p "$W/pc-$kind"
    for ex in sandstorm_visibility dust_slice_pgm avalanche_heightfield snowdrift_gl; do
        extra=""
        if [ $ex = snowdrift_gl ]; then [ -n "$gl_flags" ] || continue; extra=$gl_flags; fi
        if [ $kind = shared ]; then
            libs="$(pkg-config --libs squall) -Wl,-rpath,$LIBDIR"
        else
            libs=$(pkg-config --static --libs squall | sed 's/-lsquall\b/-l:libsquall.a/')
        fi
        # shellcheck disable=SC2086
        "$CC" -std=c11 -Wall -Wextra -Werror -o "$W/pc-$kind/$ex" "$SRC/examples/$ex.c" \
            $(pkg-config --cflags squall) $libs $extra -lm 2> "$W/pc-$kind.log" ||
            fail "pkg-config, $kind: $ex: $(head -c 2000 "$W/pc-$kind.log")"
    done
    run_examples "$W/pc-$kind" "pc-$kind" "$([ $kind = shared ] && echo quick)"
done
ldd "$W/pc-static/sandstorm_visibility" | grep -q "libsquall.so" && fail "pc-static: linked to libsquall.so"

# The walkthrough of docs/api.md (its first C block) builds and runs as printed.
awk '/^```c$/ {n++; if (n == 1) {on = 1; next}} /^```$/ {on = 0} on' "$SRC/docs/api.md" > "$W/walkthrough.c"
if "$CC" -std=c11 -Wall -Wextra -Werror -o "$W/walkthrough" "$W/walkthrough.c" \
        $(pkg-config --cflags --libs squall) -Wl,-rpath,"$LIBDIR" 2> "$W/walk.log"; then
    out=$("$W/walkthrough" 2>&1) || fail "docs/api.md walkthrough: $out"
    echo "$out" | grep -Eq "^visibility_min_h0_m = [0-9]+ m$" || fail "docs/api.md walkthrough printed: $out"
    echo "$out" | grep -q "dust_mass_concentration \[kg m-3\]: 32x32x12" || fail "docs/api.md walkthrough printed: $out"
else
    fail "docs/api.md walkthrough does not build: $(head -c 2000 "$W/walk.log")"
fi

[ "$fails" = 0 ] && echo "ok: installed package; 4 link variants built and ran the examples"
exit $((fails > 0))
