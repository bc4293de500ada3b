#!/bin/bash
# label: unit
# Bad avalanche input through the CLI (issue 6, "Bad input"): each case exits 2 with one line on
# stderr that names the key, its value and the rule, and writes no file (lib.sh: expect).
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
SLOPE="$SRC/tests/cli/data/slope-avalanche.yaml"
L=layers.slide
# particle spacing and support radius <= 0 (the parameter table's range; 0 support = auto)
expect 2 "slope-avalanche.yaml \(--set\): layers.slide.particles.spacing_m = 0 m: outside the range \[0.001, 100\] m" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.particles.spacing_m=0
expect 2 "particles.spacing_m = -0.5 m: outside the range \[0.001, 100\] m" -- \
    render "$SLOPE" -o v.mp4 --set $L.particles.spacing_m=-0.5
expect 2 "particles.support_radius_m = -1 m: outside the range \[0, 400\] m" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.particles.support_radius_m=-1
# a support the spacing cannot use (the rule behind "0 = 2 x spacing")
expect 2 "layers.slide.particles.support_radius_m = 0.5 m is 0.667 x the spacing 0.75 m; must be 1.5 to 4 x the spacing" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.particles.support_radius_m=0.5
# release zone outside the terrain (500 x 400 m, centred on the origin)
expect 2 "layers.slide.release: x \[882, 918\] m, y \[-15, 15\] m \(release.x_m = 900, .*\) lies outside the terrain x \[-250, 250\] m" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.release.x_m=900
expect 2 "layers.slide.release: .*\(release.x_m = -40, release.y_m = 190, .*\) lies outside the terrain .*y \[-200, 200\] m" -- \
    render "$SLOPE" -o v.mp4 --set $L.release.y_m=190
# too many particles for memory: a 120 x 170 m slab 10 m deep at 8 cm is ~4.6e8 particles,
# ~220 GiB; refused before allocating, naming the count and the bytes
expect 2 "layers.slide.particles.spacing_m = 0.08 m: a release of 2.33[0-9]e\+05 m3 makes about [0-9]{9} particles, which needs [0-9]{12} bytes \([0-9.]+ GiB\); the memory limit is" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.particles.spacing_m=0.08 \
    --set $L.release.length_m=120 --set $L.release.width_m=170 --set $L.release.x_m=-10 \
    --set $L.release.depth_m=10
# beyond the solver's index range (more than 2^29 particles): also refused with the count
expect 2 "layers.slide.particles.spacing_m = 0.01 m \(support 0.02 m\): the release makes about [0-9]+ particles and the SPH solver refuses the set-up" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.particles.spacing_m=0.01
# the documented minimum spacing (1 mm) on the 3291 m3 release: ~3.3e12 particles. The count is
# estimated in O(cells) and refused at once (it used to be counted one by one, ~40 min); the
# timeout only guards against a hang
before=$(snapshot "$T")
timeout 120 "$SQ" simulate "$SLOPE" --metrics m.csv --set $L.particles.spacing_m=0.001 \
    > out.txt 2> err.txt
rc=$?
[ "$rc" = 2 ] || fail "spacing 1 mm: exit $rc (124 = still counting after 120 s): $(cat err.txt)"
grep -Eq "particles.spacing_m = 0.001 m .*makes about [0-9]+ particles" err.txt \
    || fail "spacing 1 mm: $(cat err.txt)"
rm -f out.txt err.txt
[ "$before" = "$(snapshot "$T")" ] || fail "spacing 1 mm: files changed"
# rheology outside its physical range: mu0 < mu_inf (Cross), n <= 0
expect 2 "layers.slide.rheology.mu0_pa_s = 0.5 is below layers.slide.rheology.mu_inf_pa_s = 1; the Cross model needs mu0 >= mu_inf" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.rheology.mu0_pa_s=0.5
expect 2 "layers.slide.rheology.mu0_pa_s = 2 is below layers.slide.rheology.mu_inf_pa_s = 5" -- \
    render "$SLOPE" -o v.mp4 --set $L.rheology.mu0_pa_s=2 --set $L.rheology.mu_inf_pa_s=5
expect 2 "rheology.cross_n = 0: outside the range \[1e-06, 20\]" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.rheology.cross_n=0
expect 2 "rheology.power_n = -1: outside the range \[1e-06, 20\]" -- \
    simulate "$SLOPE" --metrics m.csv --set $L.rheology.model=power-law \
    --set $L.rheology.power_n=-1
# the same rules from a scene file (key path with file:line of the key the rule names)
cat > s.yaml <<YAML
name: bad-avalanche
world: {terrain: {kind: mountain, size_m: [200, 100], resolution: [41, 21]}}
camera: {position: [0, -150, 60], target: [0, 0, 0]}
output: {width: 64, height: 48, fps: 4, frames: 2, video: out.mp4}
layers:
  - type: avalanche
    particles: {spacing_m: 1}
    release: {x_m: -40, length_m: 10, width_m: 10, depth_m: 2}
    rheology: {model: cross, mu0_pa_s: 1, mu_inf_pa_s: 10}
YAML
expect 2 "s.yaml:9:[0-9]+: layers.avalanche.rheology.mu0_pa_s = 1 is below layers.avalanche.rheology.mu_inf_pa_s = 10" -- simulate s.yaml --metrics m.csv
expect 2 "cross_n = -2: outside the range" -- render s.yaml --set layers.avalanche.rheology.cross_n=-2
finish
