#!/bin/bash
# label: unit
# Every key named in an error, warning or advice text exists (tests/reliability/check_message_keys.py).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
python3 "$SRC/tests/reliability/check_message_keys.py" "$SQ" "$SRC" || fail "messages name keys that do not exist"
finish
