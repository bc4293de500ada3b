#!/bin/bash
# label: unit
# Heightmaps must be 16-bit greyscale PNGs of bounded size.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
png_file rgb8.png 16 16 8 2
png_file big.png 20000 20000 16 0 nodata
printf 'not a png' > junk.png
hm_scene() {
    cat > "$1" <<YAML
world:
  terrain: {kind: heightmap, heightmap: $2, metres_per_px: 5, height_max_m: 100}
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
}
hm_scene a.yaml rgb8.png
expect 2 "rgb8.png.*8-bit.*16-bit greyscale PNG is required" -- render a.yaml
hm_scene b.yaml big.png
expect 2 "big.png.*20000x20000.*at most" -- render b.yaml
hm_scene c.yaml junk.png
expect 2 "junk.png" -- render c.yaml
hm_scene d.yaml missing.png
expect 2 "missing.png.*No such file" -- render d.yaml
finish
