#!/bin/bash
# label: unit
# Value out of range: the message gives the range and the unit.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
expect 2 "camera.fov_deg = 500 deg: outside the range \[1, 170\] deg" -- render s.yaml --set camera.fov_deg=500
expect 2 "world.sun.latitude_deg = -95 deg: outside the range \[-90, 90\] deg" -- simulate s.yaml --set world.sun.latitude_deg=-95
finish
