#!/bin/bash
# label: unit
# Output in a missing directory: refused before any work, nothing created.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
expect 2 "no/such/dir.*does not exist" -- render s.yaml -o no/such/dir/x.mp4
expect 2 "missing/.*does not exist" -- simulate s.yaml --metrics missing/m.csv
finish
