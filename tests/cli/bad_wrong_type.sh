#!/bin/bash
# label: unit
# Wrong type: exit 2 naming file, key and the expected type.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
sed -i 's/fps: 4/fps: four/' s.yaml
expect 2 "s.yaml:5:[0-9]+: output.fps = 'four': expected a whole number" -- render s.yaml
tiny_scene s2.yaml
expect 2 "camera.position = 'up': expected 3 numbers" -- render s2.yaml --set camera.position=up
finish
