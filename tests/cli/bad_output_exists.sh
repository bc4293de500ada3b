#!/bin/bash
# label: unit
# An existing output is never replaced without --overwrite (bytes and mtime unchanged).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
echo "precious" > out.mp4
touch -d '2001-01-01' out.mp4
expect 2 "'out.mp4' exists; pass --overwrite" -- render s.yaml -o out.mp4
[ "$(cat out.mp4)" = precious ] || fail "out.mp4 was changed"
[ "$(stat -c %Y out.mp4)" = "$(date -d 2001-01-01 +%s)" ] || fail "out.mp4 mtime changed"
echo "keep" > m.csv
expect 2 "'m.csv' exists; pass --overwrite" -- simulate s.yaml --metrics m.csv
finish
