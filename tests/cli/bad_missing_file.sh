#!/bin/bash
# label: unit
# Missing or unreadable scene file, unknown preset.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
expect 2 "cannot open scene file 'nope.yaml': No such file or directory" -- render nope.yaml
tiny_scene locked.yaml
chmod 000 locked.yaml
if [ "$(id -u)" != 0 ]; then
    expect 2 "cannot open scene file 'locked.yaml': Permission denied" -- render locked.yaml
fi
chmod 644 locked.yaml
mkdir adir.yaml
expect 2 "'adir.yaml': it is a directory" -- render adir.yaml
expect 2 "'no-such-preset' is neither a scene file nor a preset \(presets: .*terrain-flight" -- render no-such-preset
finish
