#!/bin/bash
# label: unit
# Bad input of the snow cover (issue 11) through the CLI: a negative snowfall rate or density,
# and the rules that relate keys, are refused with exit code 2 and one line naming the key, its
# value and the rule, before anything is written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
cat > cover.yaml <<'YAML'
name: cover
world:
  terrain: {kind: flat, size_m: [200, 200], resolution: [17, 17]}
camera: {position: [30, -40, 8], target: [0, 0, 2]}
layers:
  - type: snowcover
    name: snow
    flakes: {count: 100}
output: {width: 64, height: 48, fps: 4, frames: 2}
YAML
expect 2 "layers.snow.snowfall.rate_mmh = -1.*0" -- \
    simulate cover.yaml --frames 1 --metrics m.csv --set layers.snow.snowfall.rate_mmh=-1
expect 2 "layers.snow.snowfall.density_kgm3 = -100" -- \
    simulate cover.yaml --frames 1 --metrics m.csv --set layers.snow.snowfall.density_kgm3=-100
expect 2 "layers.snow.occlusion.taps = 3.*1, 4 \(S2\), 5 or 9" -- \
    simulate cover.yaml --frames 1 --metrics m.csv --set layers.snow.occlusion.taps=3
expect 2 "layers.snow.flakes.near_m = 90.*below flakes.reach_m = 80" -- \
    simulate cover.yaml --frames 1 --metrics m.csv --set layers.snow.flakes.near_m=90
[ -e m.csv ] && fail "m.csv was written"
finish
