#!/bin/bash
# label: unit
# Mesh files in scenes: missing, unreadable, corrupt (one that crashes assimp), unsupported, placed off the terrain, too large
# for memory, and a procedural place larger than the terrain: exit 2, one line naming the file or key
# and the rule, nothing written.
. "$SQ_SOURCE_DIR/tests/cli/lib.sh"
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nf 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 3 4 8 7\nf 1 5 8 4\nf 2 3 7 6\n' > cube.obj
printf 'this is not a glTF binary' > junk.glb
printf 'solid x\nendsolid x\n' > model.stl
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 8000000000\nproperty list uchar int vertex_indices\nend_header\n' > huge.ply
mesh_scene() {
    cat > "$1" <<YAML
world:
  terrain: {kind: flat, size_m: [200, 200], resolution: [17, 17]}
  meshes:
    - {file: $2, position: [$3, 0], scale: 2}
camera: {position: [-50, -50, 30], target: [0, 0, 0]}
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
}
mesh_scene a.yaml missing.obj 0
expect 2 "a.yaml:[0-9]+:[0-9]+: world.meshes\[0\].file: .*missing.obj.*No such file" -- render a.yaml
mesh_scene b.yaml junk.glb 0
expect 2 "world.meshes\[0\].file: mesh '.*junk.glb' is corrupt or unreadable" -- render b.yaml
mesh_scene c.yaml model.stl 0
expect 2 "world.meshes\[0\].file: .*model.stl.*unsupported format '.stl'; supported: glTF 2.0" -- render c.yaml
mesh_scene d.yaml cube.obj 99.5
expect 2 "d.yaml:[0-9]+:[0-9]+: world.meshes\[0\]: mesh cube.obj at \(99.5, 0\): its footprint x 99.5..101.5 m.*reaches outside the terrain \(x -100..100 m" -- render d.yaml
# a damaged PLY that crashes assimp's reader (found by fuzz_mesh): the importer runs assimp in a
# child process, so the crash is a refusal of the file, not of squall
tail -c +2 "$SQ_SOURCE_DIR/tests/fuzz/regress/mesh/ply-binary-header-without-end-crashes-assimp" > crash.ply
mesh_scene f.yaml crash.ply 0
expect 2 "world.meshes\[0\].file: mesh '.*crash.ply' is corrupt: the importer \(assimp\) crashed on it \(signal" -- simulate f.yaml
mesh_scene e.yaml huge.ply 0
expect 2 "world.meshes\[0\].file: .*huge.ply.*declares 4000000000 vertices and 8000000000 faces.*needs [0-9]+ bytes.*memory limit" -- render e.yaml
if [ "$(id -u)" != 0 ]; then
    cp cube.obj locked.obj && chmod 000 locked.obj
    mesh_scene f.yaml locked.obj 0
    expect 2 "world.meshes\[0\].file: .*locked.obj.*Permission denied" -- render f.yaml
    chmod 644 locked.obj
fi
cat > g.yaml <<YAML
world:
  terrain: {kind: flat, size_m: [500, 500], resolution: [17, 17]}
  place: {kind: suburb, size_m: [1000, 400]}
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
expect 2 "g.yaml: world.place.size_m = \[1000, 400\] .* reaches outside the terrain" -- render g.yaml
cat > h.yaml <<YAML
world:
  terrain: {kind: flat, size_m: [500, 500], resolution: [17, 17]}
  place: {kind: village}
output: {width: 64, height: 48, frames: 1, video: out.mp4}
YAML
expect 2 "h.yaml:[0-9]+:[0-9]+: .*place.kind.*village" -- render h.yaml
finish
