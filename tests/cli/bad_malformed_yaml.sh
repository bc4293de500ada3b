#!/bin/bash
# label: unit
# Malformed YAML: file:line:column.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
printf 'world:\n  terrain: {kind: flat\ncamera:\n  fov_deg: 3\n' > bad.yaml
expect 2 "bad.yaml:[0-9]+:[0-9]+: malformed YAML" -- render bad.yaml
printf 'output:\n  fps: 1\n   width: 3\n' > bad2.yaml
expect 2 "bad2.yaml:3:[0-9]+: malformed YAML" -- simulate bad2.yaml
finish
