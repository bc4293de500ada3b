#!/bin/bash
# label: render
# requires: gl
# Frame size 0, odd for MP4, or beyond the GL implementation's limit.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
expect 2 "output.width = 0 px: outside the range" -- render s.yaml --size 0x48
expect 2 "--size 64: expected WIDTHxHEIGHT" -- render s.yaml --size 64
expect 2 "65x48.*even" -- render s.yaml --size 65x48
expect 2 "40000.*(limit|GL_MAX)" -- render s.yaml --size 40000x48 -o frames
finish
