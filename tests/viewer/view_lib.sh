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
        # a display number of this call's own: a block of 8 per test process (parallel tests do
        # not share), a new number for each call of the test (the previous server's lock may
        # still be there), and -a moves on past a number still in use
        SQ_VIEW_CALLS=$(( ${SQ_VIEW_CALLS:-0} + 1 ))
        xvfb-run -a -n $((200 + ($$ % 4000) * 8 + SQ_VIEW_CALLS % 8)) -s "-screen 0 1280x800x24" "$SQ" view "$@"
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
