#!/bin/bash
# label: unit
# An existing output is never replaced without --overwrite (bytes and mtime unchanged), and a
# FIFO or device is never replaced by a file, even with --overwrite.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
echo "precious" > out.mp4
touch -d '2001-01-01' out.mp4
expect 2 "'out.mp4' exists; pass --overwrite" -- render s.yaml -o out.mp4
[ "$(cat out.mp4)" = precious ] || fail "out.mp4 was changed"
[ "$(stat -c %Y out.mp4)" = "$(date -d 2001-01-01 +%s)" ] || fail "out.mp4 mtime changed"
echo "keep" > m.csv
expect 2 "'m.csv' exists; pass --overwrite" -- simulate s.yaml --metrics m.csv
mkfifo pipe.csv
expect 2 "cannot write 'pipe.csv': it is a FIFO, not a regular file" -- \
    simulate s.yaml --metrics pipe.csv --overwrite
[ -p pipe.csv ] || fail "the FIFO pipe.csv was replaced"
expect 2 "cannot write '/dev/null': it is a character device" -- \
    simulate s.yaml --metrics /dev/null --overwrite
[ -c /dev/null ] || fail "/dev/null is no longer a device"
finish
