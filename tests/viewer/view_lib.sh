# view_lib.sh — helpers of the viewer tests (tests/viewer/*.sh): the CLI tests' lib.sh, plus
# `view ARGS...`, which runs `squall view ARGS...` in a real window: on the display there is, or
# under xvfb-run (a private X server, 24-bit, started for the command) when there is none.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
CMP="${SQ_VIEW_COMPARE:?}"
export GTK_A11Y=none   # no accessibility bus in test sessions

view() {
    if [ -n "${DISPLAY:-}" ] || [ -n "${WAYLAND_DISPLAY:-}" ]; then
        "$SQ" view "$@"
    else
        # a display number of this test's own (xvfb-run -a races when tests run in parallel)
        xvfb-run -n $((200 + $$ % 5000)) -s "-screen 0 1280x800x24" "$SQ" view "$@"
    fi
}

# json FILE EXPR: evaluates a Python expression over the JSON object d read from FILE; fails the
# test with the expression and the object when it is false.
json() {
    python3 - "$1" "$2" <<'PY' || fail "$2: $(cat "$1")"
import json, sys
d = json.load(open(sys.argv[1]))
sys.exit(0 if eval(sys.argv[2]) else 1)
PY
}
