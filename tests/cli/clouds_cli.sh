#!/bin/bash
# label: smoke
# requires: gl
# The clouds phenomenon (issue 10) through the CLI: parameters listed, an analytic cumulus scene
# rendered with its metrics, the benchmark's JSON keys, and bad input refused with exit code 2 and
# one line naming the key or file, the value and the rule, before anything is written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
cat > cu.yaml <<YAML
name: cumulus
world:
  terrain: {kind: flat, size_m: [30000, 30000], resolution: [33, 33]}
  sun: {direction: [0.5, -0.5, 0.6]}
camera: {position: [-9000, -8000, 1800], target: [0, 0, 1500], near_m: 5, far_m: 60000}
layers:
  - type: clouds
    source: cumulus
    particles: {count: 3000}
output: {width: 96, height: 64, fps: 4, frames: 2, time_scale: 60}
YAML
"$SQ" params clouds > p.txt 2>&1 || fail "params clouds exited $?"
grep -q "particles.count" p.txt || fail "params clouds lacks particles.count"
grep -q "cluster.sigma_phase" p.txt || fail "params clouds lacks cluster.sigma_phase"
"$SQ" render cu.yaml -o f --metrics m.csv --quiet 2> err.txt || fail "render exited $?: $(cat err.txt)"
[ -s f/frame_00001.png ] || fail "no second frame"
head -1 m.csv | grep -q "clouds.cloud_cover_fraction" || fail "metrics lack the cover: $(head -1 m.csv)"
head -1 m.csv | grep -q "clouds.lwp_g_m2" || fail "metrics lack the liquid water path"
grep -qi nan m.csv && fail "NaN in metrics: $(cat m.csv)"
cover=$(awk -F, 'NR == 2 {print $3}' m.csv)
awk -v c="$cover" 'BEGIN {exit !(c > 0 && c < 1)}' || fail "cover fraction $cover not in (0, 1)"
# volume mode through the same scene
"$SQ" render cu.yaml -o v --frames 1 --set layers.clouds.mode=volume --quiet 2> err.txt \
    || fail "volume mode exited $?: $(cat err.txt)"
# the benchmark's keys (not its speed)
"$SQ" bench clouds --only frame --particles 1500 --reps 1 --warmup 0 --width 64 --height 48 \
    > b.json 2> err.txt || fail "bench clouds exited $?: $(cat err.txt)"
for k in particles clusters ms_light ms_draw ms_per_frame; do
    grep -q "\"$k\"" b.json || fail "bench clouds output lacks $k: $(cat b.json)"
done
rm -rf f v m.csv b.json p.txt err.txt
# too many particles for the clouds' volume: refused before allocating, count and bytes named
expect 2 "(layers.clouds|sq_clouds_desc).particles.per_km3 = 1e\+12 over [0-9.e+-]+ km3 of cloud: [0-9]+ particles x 200 bytes needs [0-9]+ bytes" -- \
    simulate cu.yaml --metrics m.csv --set layers.clouds.particles.per_km3=1e12
# source wrf without a file
expect 2 "layers.clouds.wrf.file is empty; source = wrf needs" -- \
    simulate cu.yaml --metrics m.csv --set layers.clouds.source=wrf
# a file that is not NetCDF, and one that does not exist
printf 'not a netcdf file\n' > bad.nc
expect 2 "bad.nc" -- simulate cu.yaml --metrics m.csv --set layers.clouds.source=wrf \
    --set layers.clouds.wrf.file=bad.nc
expect 2 "missing.nc" -- simulate cu.yaml --metrics m.csv --set layers.clouds.source=wrf \
    --set layers.clouds.wrf.file=missing.nc
# impostor band inverted
expect 2 "layers.clouds.impostor.dist_m = 1000 m is below impostor.dist_3d_m = 5000 m" -- \
    simulate cu.yaml --metrics m.csv --set layers.clouds.impostor.dist_3d_m=5000 \
    --set layers.clouds.impostor.dist_m=1000
# out of range threshold
expect 2 "cloud.threshold_g_m3 = -1 g/m3: outside the range" -- \
    simulate cu.yaml --metrics m.csv --set layers.clouds.cloud.threshold_g_m3=-1
finish
