#!/bin/bash
# label: unit
# Malformed YAML: file:line:column; a tab in the indentation is named as the cause (YAML
# indents with spaces only; libyaml's own message does not say so), and only then.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
printf 'world:\n  terrain: {kind: flat\ncamera:\n  fov_deg: 3\n' > bad.yaml
expect 2 "bad.yaml:[0-9]+:[0-9]+: malformed YAML" -- render bad.yaml
printf 'output:\n  fps: 1\n   width: 3\n' > bad2.yaml
expect 2 "bad2.yaml:3:[0-9]+: malformed YAML" -- simulate bad2.yaml
printf 'name: x\nlayers:\n\t- type: sandstorm\n' > tab.yaml
expect 2 "tab.yaml:3:1: malformed YAML.*indented with a tab; YAML indents with spaces only" -- simulate tab.yaml
printf 'name: x\t# a tab after the value is fine\noutput:\n  fps: 1\n   width: 3\n' > notab.yaml
expect 2 "notab.yaml:4:[0-9]+: malformed YAML[^(]*$" -- simulate notab.yaml
finish
