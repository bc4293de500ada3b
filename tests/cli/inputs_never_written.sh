#!/bin/bash
# label: unit
# Inputs are never written (issue 17 part 1): an output that is, or resolves to, the scene file
# or the heightmap is refused before any work, with or without --overwrite, by name, through a
# symlink or a hard link; inputs that are not regular files are refused at once; temporaries
# that a killed run left next to an output are removed by the next run.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
sed -i 's/video: out.mp4/video: ""/' s.yaml
expect 2 "output 's.yaml' is the scene file 's.yaml': inputs are never written, not even with --overwrite" -- simulate s.yaml --metrics s.yaml --overwrite
expect 2 "output 's.yaml' is the scene file" -- simulate s.yaml --metrics s.yaml
ln -s s.yaml link.csv
expect 2 "output 'link.csv' is the scene file 's.yaml' \(the same file through a link\)" -- simulate s.yaml --metrics link.csv --overwrite
ln s.yaml hard.csv
expect 2 "output 'hard.csv' is the scene file 's.yaml'" -- simulate s.yaml --metrics hard.csv --overwrite
ln -s s.yaml clip.mp4
expect 2 "output 'clip.mp4' is the scene file" -- render s.yaml -o clip.mp4 --overwrite
# the heightmap: as a frame of the frames directory, and as a field file
python3 - <<'PY'
import struct, zlib
w = h = 16
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
rows = b"".join(b"\0" + b"".join(struct.pack(">H", 1000 * ((x + y) % 7)) for x in range(w)) for y in range(h))
open("hm.png", "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))
PY
cat > hm.yaml <<'YAML'
world:
  terrain: {kind: heightmap, heightmap: hm.png, metres_per_px: 10, height_max_m: 20}
camera: {position: [-50, -50, 60], target: [0, 0, 0]}
output: {width: 64, height: 48, fps: 4, frames: 1, video: ""}
YAML
mkdir frames
ln -s ../hm.png frames/frame_00000.png
expect 2 "output 'frames/frame_00000.png' is the heightmap 'hm.png'" -- render hm.yaml -o frames --overwrite
rm frames/frame_00000.png
ln hm.png f_snow_depth_00000.png
expect 2 "output 'f_snow_depth_00000.png' is the heightmap 'hm.png'" -- simulate hm.yaml --fields f --overwrite
rm f_snow_depth_00000.png
# not regular files: refused at once (timeout turns a block into a failure)
mkfifo fifo.yaml
timeout 20 "$SQ" render fifo.yaml > out.txt 2> err.txt
rc=$?
[ "$rc" = 2 ] || fail "FIFO scene: exit $rc, expected 2 (124 = it blocked)"
grep -q "fifo.yaml': it is a FIFO" err.txt || fail "FIFO scene: $(cat err.txt)"
rm -f fifo.yaml out.txt err.txt
# a temporary left by a killed run (its process is gone) is removed by the next run, and said so
sh -c 'exit 0' & dead=$!
wait $dead
touch ".m.csv.tmp-$dead-0"
"$SQ" simulate s.yaml --metrics m.csv 2> err.txt || fail "simulate exited $?: $(cat err.txt)"
[ -e ".m.csv.tmp-$dead-0" ] && fail "the stale temporary .m.csv.tmp-$dead-0 is still there"
grep -q "removed './.m.csv.tmp-$dead-0': a temporary left by an interrupted run" err.txt ||
    fail "the removal was not reported: $(cat err.txt)"
[ -s m.csv ] || fail "no metrics written"
rm -f err.txt
finish
