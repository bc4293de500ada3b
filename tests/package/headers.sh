#!/bin/bash
# label: unit
# Every public header compiles alone as C11 and as C++17 (strict warnings, -Werror), and the
# umbrella header squall/squall.h includes every header of include/squall/, and every public
# function has a comment (ownership, units, errors: docs/api.md).
set -u
SRC="${SQ_SOURCE_DIR:?}"
CC="${SQ_CC:-cc}"
CXX="${SQ_CXX:-g++}"
fails=0
for h in "$SRC"/include/squall/*.h; do
    n=$(basename "$h")
    if ! echo "#include \"squall/$n\"" | "$CC" -std=c11 -Wall -Wextra -Wpedantic -Wstrict-prototypes \
            -Wshadow -Werror -fsyntax-only -I "$SRC/include" -x c - 2> err.txt; then
        echo "FAIL: squall/$n alone as C11: $(cat err.txt)"; fails=$((fails + 1))
    fi
    if ! echo "#include \"squall/$n\"" | "$CXX" -std=c++17 -Wall -Wextra -Wpedantic -Werror \
            -fsyntax-only -I "$SRC/include" -x c++ - 2> err.txt; then
        echo "FAIL: squall/$n alone as C++17: $(cat err.txt)"; fails=$((fails + 1))
    fi
    if [ "$n" != squall.h ] && ! grep -q "#include \"squall/$n\"" "$SRC/include/squall/squall.h"; then
        echo "FAIL: squall/squall.h does not include squall/$n"; fails=$((fails + 1))
    fi
done
# Opaque handles stay opaque: every type the headers declare as `typedef struct sq_x sq_x;` is
# incomplete for a user (sizeof fails), so its layout is not part of the ABI (docs/api.md); the
# world (256 inline obstacles, caches) must be one of them.
handles=$(sed -n 's/^typedef struct \(sq_[a-z0-9_]*\) \1;.*/\1/p' "$SRC"/include/squall/*.h | sort -u)
echo "$handles" | grep -qx sq_world || { echo "FAIL: sq_world is not an opaque handle"; fails=$((fails + 1)); }
for t in $handles; do
    if printf '#include "squall/squall.h"\nunsigned long n = sizeof(%s);\n' "$t" | "$CC" -std=c11 \
            -fsyntax-only -I "$SRC/include" -x c - 2> err.txt; then
        echo "FAIL: $t has a public layout (sizeof compiles)"; fails=$((fails + 1))
    elif ! grep -q 'incomplete' err.txt; then
        echo "FAIL: sizeof($t): not the expected incomplete-type error: $(head -3 err.txt)"
        fails=$((fails + 1))
    fi
done
# Every public function is documented: a comment on its line, or a comment ending right above
# it or above the run of declarations it belongs to (a group documented together).
undoc=$(awk '
    FNR == 1 { prev_doc = 0; in_group = 0 }
    /^SQ_API/ {
        if (!(prev_doc || in_group_doc || index($0, "/*"))) print FILENAME ":" FNR ": " $0
        in_group = 1; in_group_doc = (prev_doc || in_group_doc || index($0, "/*")); prev_doc = 0; next
    }
    in_group && /^ / && !/^ *(\/\*|\*)/ { next }   # continuation of a declaration
    { in_group = 0; in_group_doc = 0; prev_doc = ($0 ~ /\*\/ *$/) }
' "$SRC"/include/squall/*.h)
if [ -n "$undoc" ]; then
    echo "FAIL: public functions without documentation:"; echo "$undoc"; fails=$((fails + 1))
fi
rm -f err.txt
[ "$fails" = 0 ] && echo "ok: $(ls "$SRC"/include/squall/*.h | wc -l) headers, $(echo "$handles" | wc -w) opaque handles"
exit $((fails > 0))
