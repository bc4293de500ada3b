#!/bin/bash
# label: render
# requires: gl
# No usable GL context: exit 1, and the message says how to get one.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
export LIBGL_DRIVERS_PATH=/nonexistent EGL_PLATFORM=surfaceless GBM_BACKENDS_PATH=/nonexistent
export __EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json
expect 1 "OpenGL.*(install|driver)" -- render s.yaml
finish
