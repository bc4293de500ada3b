#!/bin/bash
# run_fuzz.sh EXE NAME — runs one libFuzzer harness for $SQ_FUZZ_SECONDS (default 10) seconds.
# With SQ_FUZZ_SEED set (make test does: CI), libFuzzer's mutations start from that seed, so a
# finding in CI is found again by the same command on the same tree; without it (make fuzz) every
# run explores from a new random seed.
# New inputs go to a working corpus in the build directory (fuzz-work/NAME), never into the
# repository; the repository's corpus/NAME and regress/NAME are read as extra seed directories.
# Limits: 10 s per input (a hang is a finding), 2048 MiB RSS, 512 MiB for one allocation.
# A finding leaves its input in fuzz-work/artifacts/ and fails the run; the last lines of
# libFuzzer's report are printed. A summary line is appended to fuzz-work/fuzz-log.tsv:
# date, harness, seconds, executions, result.
set -u
EXE="$1"
NAME="$2"
SECS="${SQ_FUZZ_SECONDS:-10}"
SEED=()
[ -n "${SQ_FUZZ_SEED:-}" ] && SEED=(-seed="$SQ_FUZZ_SEED")
SRC="${SQ_SOURCE_DIR:?}"
WORK="${SQ_FUZZ_WORK:-$PWD/fuzz-work}"
mkdir -p "$WORK/$NAME" "$WORK/artifacts"
SEEDS=()
for d in "$SRC/tests/fuzz/corpus/$NAME" "$SRC/tests/fuzz/regress/$NAME"; do
    [ -d "$d" ] && SEEDS+=("$d")
done
LOG="$WORK/$NAME.log"
ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}" \
UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}" \
    "$EXE" "${SEED[@]}" -max_total_time="$SECS" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$WORK/artifacts/$NAME-" \
    "$WORK/$NAME" "${SEEDS[@]}" >"$LOG" 2>&1
rc=$?
runs=$(grep -Eo 'stat::number_of_executed_units: *[0-9]+' "$LOG" | grep -Eo '[0-9]+$' | tail -1)
result=ok
[ "$rc" = 0 ] || result="FINDING (exit $rc)"
printf '%s\t%s\t%s\t%s\t%s\n' "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$NAME" "$SECS" "${runs:-?}" \
    "$result" >>"$WORK/fuzz-log.tsv"
echo "fuzz $NAME: ${runs:-?} inputs in $SECS s: $result"
if [ "$rc" != 0 ]; then
    tail -n 60 "$LOG"
    ls -1 "$WORK/artifacts" | grep "^$NAME-" | sed "s|^|artifact: $WORK/artifacts/|"
    exit 1
fi
