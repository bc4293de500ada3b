#!/bin/bash
# label: regression
# Checkpoint and resume (issue 17 part 4), for each phenomenon: a run of N frames is the
# reference; a second run writes a checkpoint and stops (at a frame limit, or killed with
# SIGKILL right after its checkpoint appeared); `--resume` continues it. The resumed run's
# metrics rows and its last field file must equal the reference's byte for byte (bit-identical
# continuation). Then the refusals: a damaged or truncated checkpoint, a changed input, a physics
# override on resume.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
SANDSTORM=(desert-sandstorm --set layers.storm.domain.nx=16 --set layers.storm.domain.ny=16
           --set layers.storm.domain.nz=8)
cat > snow.yaml <<'YAML'
seed: 3
world:
  terrain: {kind: flat, material: snow, size_m: [200, 200], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
layers:
  - type: snowdrift
    name: snow
    domain: {nx: 32, ny: 24, nz: 16, cell_size_m: 2}
    wind: {speed_mps: 6, beaufort: 3}
    snow: {snowfall_mmh: 4, speedup: 2000}
    draw: {flakes: 200}
output: {fps: 4, frames: 8}
YAML
AVALANCHE=("$SRC/tests/cli/data/slope-avalanche.yaml" --threads 1)  # procedural: no GDAL needed
cat > cover.yaml <<'YAML'
seed: 4
world:
  terrain: {kind: hills, size_m: [300, 300], resolution: [33, 33], relief_m: 5}
  obstacles:
    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}
camera: {position: [30, -40, 8], target: [0, 0, 2]}
layers:
  - type: snowcover
    name: cover
    snowfall: {rate_mmh: 3, speedup: 600}
    flakes: {count: 3000, turbulence_mps: 0.5, spin_rad_s: 2}
output: {fps: 4, frames: 8}
YAML

# same_tail REF RESUMED: the rows of RESUMED equal the rows of REF with the same frame numbers
same_tail() {
    python3 - "$1" "$2" <<'PY'
import sys
ref = open(sys.argv[1]).read().splitlines()
res = open(sys.argv[2]).read().splitlines()
if ref[0] != res[0]:
    sys.exit("headers differ")
rows = {l.split(",", 1)[0]: l for l in ref[1:]}
if len(res) < 2:
    sys.exit("the resumed run wrote no rows")
for l in res[1:]:
    f = l.split(",", 1)[0]
    if rows.get(f) != l:
        sys.exit("frame %s differs:\n reference %s\n resumed   %s" % (f, rows.get(f), l))
print("frames %s..%s identical" % (res[1].split(",")[0], res[-1].split(",")[0]))
PY
}

# check NAME FRAMES EVERY SCENE-ARGS...: reference, stopped run with a checkpoint, resume
check() {
    local name="$1" frames="$2" every="$3"
    shift 3
    "$SQ" simulate "$@" --frames "$frames" --metrics "$name-ref.csv" --fields "$name-ref" \
        --set output.fields_format=vtk --quiet 2> err.txt || fail "$name reference: $(cat err.txt)"
    "$SQ" simulate "$@" --frames $((frames / 2)) --checkpoint-every "$every" \
        --checkpoint "$name.ckpt" --quiet 2> err.txt || fail "$name checkpointing run: $(cat err.txt)"
    [ -s "$name.ckpt" ] || { fail "$name: no checkpoint written"; return; }
    "$SQ" simulate --resume "$name.ckpt" --frames "$frames" --metrics "$name-res.csv" \
        --fields "$name-res" --set output.fields_format=vtk --quiet 2> err.txt ||
        fail "$name resume: $(cat err.txt)"
    same_tail "$name-ref.csv" "$name-res.csv" > cmp.txt 2>&1 || fail "$name: $(cat cmp.txt)"
    last=$(printf '%05d' $((frames - 1)))
    for f in "$name-ref_$last.vti" "$name-ref_maps_$last.vti"; do
        [ -e "$f" ] || continue
        cmp -s "$f" "${f/-ref/-res}" || fail "$name: $f and ${f/-ref/-res} differ"
    done
}
check sandstorm 6 1.0 "${SANDSTORM[@]}"
# the haboob (issue 12): cold-pool inflow, temperature background, front history
HABOOB=(haboob --set layers.storm.domain.nx=24 --set layers.storm.domain.ny=16
        --set layers.storm.domain.nz=12 --set layers.storm.coldpool.depth_m=300
        --set layers.storm.coldpool.length_m=300 --set layers.storm.near.particles=200)
check haboob 6 1.0 "${HABOOB[@]}"
check snowdrift 8 0.75 snow.yaml
check avalanche 6 0.15 "${AVALANCHE[@]}"
check clouds 6 100 wrf-clouds --set layers.clouds.particles.count=2000
check snowcover 8 0.75 cover.yaml

# killed with SIGKILL right after a checkpoint: the checkpoint is whole (written atomically) and
# resumes to the same result
"$SQ" simulate snow.yaml --frames 40 --checkpoint-every 0.25 --checkpoint killed.ckpt \
    --metrics killed.csv --quiet 2> /dev/null &
pid=$!
for i in $(seq 1 600); do [ -s killed.ckpt ] && break; sleep 0.1; done
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null
if [ -s killed.ckpt ]; then
    "$SQ" simulate snow.yaml --frames 40 --metrics full40.csv --quiet 2> err.txt || fail "snow 40: $(cat err.txt)"
    # the resumed run writes the same metrics file: the killed run's temporary of it goes
    "$SQ" simulate --resume killed.ckpt --metrics killed.csv --quiet 2> err.txt ||
        fail "resume after SIGKILL: $(cat err.txt)"
    same_tail full40.csv killed.csv > cmp.txt 2>&1 || fail "after SIGKILL: $(cat cmp.txt)"
    ls -a | grep -q "^\.killed" && fail "temporaries of the killed run are still there: $(ls -a | grep '^\.killed')"
else
    fail "the run did not write killed.ckpt"
fi

# refusals
cp snowdrift.ckpt bad.ckpt
printf 'X' | dd of=bad.ckpt bs=1 seek=200 conv=notrunc 2> /dev/null
expect 2 "checkpoint 'bad.ckpt' is damaged or truncated: its checksum does not match" -- simulate --resume bad.ckpt
head -c 500 snowdrift.ckpt > short.ckpt
expect 2 "checkpoint 'short.ckpt' is damaged or truncated" -- simulate --resume short.ckpt
printf 'not a checkpoint at all, long enough to pass the size test.......' > junk.ckpt
expect 2 "'junk.ckpt' is not a squall checkpoint" -- simulate --resume junk.ckpt
expect 2 "--set layers.snow.wind.speed_mps=9: cannot change this when resuming" -- simulate --resume snowdrift.ckpt --set layers.snow.wind.speed_mps=9
expect 2 "--resume snowdrift.ckpt: the scene comes from the checkpoint" -- simulate snow.yaml --resume snowdrift.ckpt
# an input (a heightmap) that changed since the checkpoint
python3 - <<'PY'
import struct, zlib
def png(path, v):
    w = h = 16
    def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    rows = b"".join(b"\0" + b"".join(struct.pack(">H", v * ((x + y) % 5)) for x in range(w)) for y in range(h))
    open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
png("hm.png", 1000)
PY
cat > hm.yaml <<'YAML'
world:
  terrain: {kind: heightmap, heightmap: hm.png, metres_per_px: 10, height_max_m: 20}
layers:
  - {type: snowdrift, name: snow, domain: {nx: 12, ny: 12, nz: 8, cell_size_m: 10}, draw: {flakes: 10}}
output: {fps: 4, frames: 4}
YAML
"$SQ" simulate hm.yaml --checkpoint-every 0.25 --checkpoint hm.ckpt --quiet 2> err.txt || fail "hm run: $(cat err.txt)"
touch -d '2001-01-01' hm.png
expect 2 "checkpoint 'hm.ckpt': the heightmap 'hm.png' changed since the checkpoint was written" -- simulate --resume hm.ckpt
finish
