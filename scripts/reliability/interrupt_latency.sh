#!/bin/bash
# interrupt_latency.sh SQUALL — how long squall takes to stop after SIGINT, in each long stage:
# terrain generation, and the frames of each built-in phenomenon preset (simulate and render).
# Sends SIGINT 3 s after the handler is installed and prints the wall time to exit. For
# docs/reliability.md; not a test (the figures depend on the machine and its load).
set -u
SQ="$1"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
cd "$T"
printf 'world: {terrain: {kind: hills, resolution: [4097, 4097], octaves: 12}}\noutput: {frames: 1}\n' > big.yaml
measure() {
    local what="$1"
    shift
    "$SQ" "$@" > /dev/null 2> err.txt &
    local pid=$!
    for i in $(seq 1 600); do
        m=$(awk '/^SigCgt:/ {print $2}' /proc/$pid/status 2>/dev/null)
        [ -n "$m" ] && [ $(( 0x$m & 2 )) != 0 ] && break
        sleep 0.05
    done
    sleep 3
    local t0 t1
    t0=$(date +%s.%N)
    if ! kill -INT $pid 2> /dev/null; then
        wait $pid
        printf '%-44s finished before the signal (%s)\n' "$what" "$(tail -1 err.txt | cut -c1-50)"
        return
    fi
    wait $pid
    t1=$(date +%s.%N)
    printf '%-44s %6.2f s  (%s)\n' "$what" "$(echo "$t1 - $t0" | bc)" "$(tail -1 err.txt | cut -c1-70)"
}
measure "terrain 4097x4097, 12 octaves" simulate big.yaml
for p in desert-sandstorm village-snowdrift alpine-avalanche wrf-clouds suburb; do
    measure "simulate $p" simulate $p --metrics m-$p.csv
    measure "render $p (640x360)" render $p -o v-$p.mp4
done
echo "load: $(uptime)"
