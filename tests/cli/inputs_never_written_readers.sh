#!/bin/bash
# label: unit
# Inputs are never written (issue 17 part 1), for the readers of WRF files, DEMs (GDAL) and
# meshes (assimp): the WRF file as the output of `squall wrf export` (by name, through a
# symlink, with --overwrite); the WRF file, the DEM and a mesh of a scene as its metrics or a
# field file. Each is refused (exit 2, one line naming the output and the input), nothing is
# written, and the input is unchanged. A mesh that is a FIFO is refused at once instead of
# blocking the open (issue 17 part 2). The inputs are copies, so a broken guard cannot damage
# the samples.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
cp "$SRC/data/wrf/wrf_d01_allvars_cropped.nc" wrf.nc
cp "$SRC/data/dem/hef_srtm.tif" dem.tif
chmod u+w wrf.nc dem.tif
before=$(sha256sum wrf.nc dem.tif)
expect 2 "output 'wrf.nc' is the WRF file 'wrf.nc': inputs are never written" -- wrf export wrf.nc --time 0 -o wrf.nc --overwrite
ln -s wrf.nc link.nc
expect 2 "output 'link.nc' is the WRF file 'wrf.nc' \(the same file through a link\)" -- wrf export wrf.nc --time 0 -o link.nc --overwrite
cat > w.yaml <<'YAML'
world:
  terrain: {kind: wrf, wrf: wrf.nc}
output: {frames: 1, video: ""}
YAML
expect 2 "output 'wrf.nc' is the WRF file" -- simulate w.yaml --metrics wrf.nc --overwrite
cat > d.yaml <<'YAML'
world:
  terrain: {kind: dem, dem: dem.tif, cell_m: 400}
output: {frames: 1, video: ""}
YAML
expect 2 "output 'dem.tif' is the DEM '(\./)?dem.tif': inputs are never written" -- simulate d.yaml --metrics dem.tif --overwrite
ln dem.tif f_00000.nc
expect 2 "output 'f_00000.nc' is the DEM '(\./)?dem.tif' \(the same file through a link\)" -- simulate d.yaml --fields f --overwrite
rm f_00000.nc
[ "$(sha256sum wrf.nc dem.tif)" = "$before" ] || fail "an input changed"
# meshes
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n' > quad.obj
mesh_scene() {
    cat > "$1" <<YAML
world:
  terrain: {kind: flat, size_m: [200, 200], resolution: [17, 17]}
  meshes:
    - {file: $2, position: [0, 0]}
output: {frames: 1, video: ""}
YAML
}
mesh_scene m.yaml quad.obj
expect 2 "output 'quad.obj' is the mesh '(\./)?quad.obj': inputs are never written" -- simulate m.yaml --metrics quad.obj --overwrite
# a mesh's texture is an input too (assimp reads it in a child process: the run records it)
python3 - <<'PY'
import struct, zlib
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
raw = b"".join(b"\x00" + bytes([200, 60, 40, 255] * 2) for _ in range(2))
open("tex.png", "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 6, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
PY
printf 'newmtl brick\nKd 1 1 1\nmap_Kd tex.png\n' > quadt.mtl
printf 'mtllib quadt.mtl\nusemtl brick\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n' > quadt.obj
mesh_scene t.yaml quadt.obj
expect 2 "output 'tex.png' is the mesh texture '(\./)?tex.png': inputs are never written" -- simulate t.yaml --metrics tex.png --overwrite
mkfifo pipe.obj
mesh_scene p.yaml pipe.obj
timeout 20 "$SQ" simulate p.yaml > out.txt 2> err.txt
rc=$?
[ "$rc" = 2 ] || fail "FIFO mesh: exit $rc, expected 2 (124 = it blocked)"
grep -q "pipe.obj': it is a FIFO" err.txt || fail "FIFO mesh: $(cat err.txt)"
rm -f pipe.obj out.txt err.txt
finish
