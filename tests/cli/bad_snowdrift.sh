#!/bin/bash
# label: unit
# Bad input of the snowdrift (issue 5) through the CLI, on the village-snowdrift preset: each is
# refused with exit code 2 and one line naming the key, its value and the rule, before anything
# is written (the metrics file asked for is not created).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
P=village-snowdrift
# relaxation time at or below 1/2 (zero or negative lattice viscosity)
expect 2 "village-snowdrift \(--set\): layers.snow.wind.tau = 0.5; must be > 0.5" -- \
    simulate $P --frames 1 --metrics m.csv --set layers.snow.wind.tau=0.5
# a lattice step too long for the wind: Mach number too high, names the knobs
expect 2 "domain.dt_s = 0.05 s: .*Mach [0-9.]+ > 0.3.*lower domain.dt_s to at most [0-9.e-]+ s" -- \
    simulate $P --frames 1 --metrics m.csv --set layers.snow.domain.dt_s=0.05
# an obstacle outside the lattice
expect 2 "world.obstacles\[0\] \(footprint x 294..306 m.*is not inside the snowdrift lattice \(x -64..64 m" -- \
    simulate $P --frames 1 --metrics m.csv --set "world.obstacles.0.center=[300, 2]"
# the same from a scene file
cat > far.yaml <<YAML
name: far-house
world:
  terrain: {kind: flat, size_m: [400, 400], resolution: [33, 33]}
  obstacles:
    - {kind: house, center: [-100, 0], size: [10, 8, 4], roof_m: 2}
layers:
  - type: snowdrift
    domain: {nx: 32, ny: 16, nz: 12}
    snow: {snowfall_mmh: 2}
output: {width: 64, height: 48, fps: 4, frames: 2}
YAML
expect 2 "world.obstacles\[0\] \(footprint x -105..-95 m.*not inside the snowdrift lattice \(x -16..16 m" -- \
    simulate far.yaml --metrics m.csv
# negative snowfall rate
expect 2 "snow.snowfall_mmh = -2 mm/h: outside the range \[0, 1000\] mm/h" -- \
    simulate $P --frames 1 --metrics m.csv --set layers.snow.snow.snowfall_mmh=-2
# a lattice too large for memory: refused before allocating, with the bytes needed
expect 2 "layer 'snow' \(snowdrift\) needs [0-9]+ bytes \([0-9.]+ GiB\); the memory limit is" -- \
    simulate $P --frames 1 --metrics m.csv --set layers.snow.domain.nx=1200 \
    --set layers.snow.domain.ny=1200 --set layers.snow.domain.nz=1200
# a lattice beyond the solver's 31-bit cell index: the lattice's rule, in the layer's keys
expect 2 "layers.snow.domain.cells = 2048x2048x2048; the padded lattice may hold at most 2\^31-1 cells" -- \
    simulate $P --frames 1 --metrics m.csv --set layers.snow.domain.nx=2048 \
    --set layers.snow.domain.ny=2048 --set layers.snow.domain.nz=2048
finish
