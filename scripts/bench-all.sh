#!/usr/bin/env bash
# Runs every benchmark of the issues and prints their JSON lines (one per measurement), with the
# machine and date first. Usage: scripts/bench-all.sh [build-dir] > bench.jsonl
# Run it on a quiet machine: the figures are what docs/performance.md records.
set -u
B="${1:-build/release}"
SQ="$B/squall"
[ -x "$SQ" ] || { echo "bench-all: $SQ not built (make build)" >&2; exit 2; }
printf '{"machine": "%s", "cpus": %s, "date": "%s", "loadavg": "%s", "gl": "%s"}\n' \
    "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')" "$(nproc)" \
    "$(date -u +%Y-%m-%dT%H:%MZ)" "$(cut -d' ' -f1-3 /proc/loadavg)" \
    "$("$SQ" info --json 2>/dev/null | sed -n 's/.*"gl_renderer": "\([^"]*\)".*/\1/p')"
run() { echo "# squall bench $*" >&2; "$SQ" bench "$@" || echo "{\"case\": \"$1\", \"error\": true}"; }
run stream
run sandstorm --grid 64
run sandstorm --grid 128 --reps 5
run grid --grid 64
run grid --grid 128 --reps 5
run lbm --size 128
run lbm --size 256x128x128 --reps 5
run sph --particles 65536
run sph --particles 262144 --reps 5
run sph --particles 1048576 --reps 3
run render-volume --reps 3
run snowdrift
