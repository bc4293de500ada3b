#!/bin/bash
# label: unit
# Two outputs of one run are never the same file (the later would silently replace the earlier,
# e.g. the checkpoint under the metrics): the run ends at once with exit 2 and one line naming
# both outputs, nothing is written, and an existing file under that name is left as it was, also
# with --overwrite. The same name spelt differently ("./out/../out/x") is the same file; the
# hazard rasters' names (DIR/summary.json, DIR/<map>.tif) are checked against the other outputs
# too, before DIR is made.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
tiny_scene s.yaml
mkdir out
expect 2 "output.metrics 'm.csv' and the checkpoint 'm.csv' are the same file" -- \
    simulate s.yaml --metrics m.csv --checkpoint-every 0.25 --checkpoint m.csv
echo "keep" > m.csv
expect 2 "output.metrics 'm.csv' and the checkpoint './out/../m.csv' are the same file" -- \
    simulate s.yaml --metrics m.csv --checkpoint-every 0.25 --checkpoint ./out/../m.csv --overwrite
[ "$(cat m.csv)" = keep ] || fail "m.csv was changed"
expect 2 "output.video 'out/v.mp4' and output.metrics 'out/../out/v.mp4' are the same file" -- \
    render s.yaml -o out/v.mp4 --metrics out/../out/v.mp4
# different names are fine: the run writes both
"$SQ" simulate s.yaml --metrics out/a.csv --checkpoint-every 0.25 --checkpoint out/a.ckpt \
    --quiet || fail "distinct outputs refused"
[ -s out/a.csv ] && [ -s out/a.ckpt ] || fail "distinct outputs not both written"
if has_feature gdal && has_feature avalanche; then
    SCENE="$SRC/tests/cli/data/dem-avalanche.yaml"
    expect 2 "--rasters 'r' writes 'r/summary.json', which is also the metrics \(output.metrics\) 'r/summary.json'" -- \
        simulate "$SCENE" --rasters r --metrics r/summary.json --set output.frames=1
    [ ! -e r ] || fail "the rasters' directory was made"
    expect 2 "--rasters 'r' writes 'r/peak_speed.tif', which is also the checkpoint \(--checkpoint\) 'r/peak_speed.tif'" -- \
        simulate "$SCENE" --rasters r --checkpoint-every 0.1 --checkpoint r/peak_speed.tif --set output.frames=1
fi
finish
