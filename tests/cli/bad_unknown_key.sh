#!/bin/bash
# label: unit
# Unknown scene key: exit 2, file:line:col, a "did you mean", nothing written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
sed -i 's/fps: 4/fsp: 4/' s.yaml
expect 2 "s.yaml:5:.*unknown key 'output.fsp'; did you mean 'output.fps'\?" -- render s.yaml
tiny_scene s2.yaml
expect 2 "unknown key 'output.widht'; did you mean 'output.width'\?" -- render s2.yaml --set output.widht=64
finish
