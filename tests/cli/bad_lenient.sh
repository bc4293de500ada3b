#!/bin/bash
# label: unit
# What used to be accepted silently or blamed on the wrong place (issue 17 part 6): an output
# extension other than .mp4 became a frame folder, --size/--fps/--frames errors were blamed on
# --set, an unclosed bracket in --set was read as a list, duplicate layer names were accepted,
# 1e30 passed as a 64-bit seed.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
expect 2 "^squall: -o out.avi: .*'.avi' is neither" -- render s.yaml -o out.avi
expect 2 "^squall: -o frames.png: " -- render s.yaml -o frames.png
expect 2 "^squall: --size 0x48: output.width = 0 px: outside the range \[16, 65536\] px" -- render s.yaml --size 0x48
expect 2 "^squall: --fps 0: output.fps = 0 1/s: outside the range" -- render s.yaml --fps 0
expect 2 "^squall: --frames 1.5: output.frames = '1.5': expected a whole number" -- simulate s.yaml --frames 1.5
expect 2 "^squall: --duration -1: output.duration_s" -- simulate s.yaml --duration -1
expect 2 "--set camera.position=\[1, 2, 3: the list opened by '\[' is not closed" -- simulate s.yaml --set 'camera.position=[1, 2, 3'
expect 2 "world.terrain.seed = '1e30': expected a whole number in 0..18446744073709551615" -- simulate s.yaml --set world.terrain.seed=1e30
expect 2 "byte 14 \(0xFF\) is not valid UTF-8" -- simulate s.yaml --set $'output.video=\xff.mp4'
cat > v.yaml <<'YAML'
world:
  terrain: {kind: flat, size_m: [400, 400], resolution: [9, 9]}
output:
  frames: 1
  video: clip.avi
YAML
expect 2 "^squall: v.yaml:5:3: output.video = 'clip.avi': squall writes H.264 video as .mp4 only" -- render v.yaml
cat > d.yaml <<'YAML'
world:
  terrain: {kind: flat, size_m: [400, 400], resolution: [9, 9]}
layers:
  - {type: snowdrift, name: snow, domain: {nx: 8, ny: 8, nz: 8, cell_size_m: 4}}
  - {type: snowdrift, name: snow, domain: {nx: 8, ny: 8, nz: 8, cell_size_m: 4}}
output: {frames: 1}
YAML
expect 2 "^squall: d.yaml:5:23: layers\[1\] is named 'snow' like an earlier layer" -- simulate d.yaml
sed -i 's/name: snow, domain/name: "a.b", domain/' d.yaml
expect 2 "d.yaml:4:23: layers\[0\].name = 'a.b': a layer name is" -- simulate d.yaml
finish
