#!/usr/bin/env bash
# Regenerates the gltfpack variants of the vendored assets that
# tests/gltf_compressed.rs renders against their sources:
#   NAME.q.glb   gltfpack defaults (KHR_mesh_quantization)
#   NAME.cc.glb  gltfpack -cc (KHR_mesh_quantization + EXT_meshopt_compression)
# Textures stay references to the originals beside them (-tr), so the
# variants are small. Needs npm (the gltfpack and gltf-pipeline packages,
# pinned below).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
version=1.3.0
pack() { npx --yes "gltfpack@$version" "$@" >/dev/null; }
for name in Box BoxTextured MultiUVTest OrientationTest NormalTangentMirrorTest AlphaBlendModeTest SimpleInstancing garage; do
    dir="$here/assets/$name"
    pack -tr -i "$dir/$name.gltf" -o "$dir/$name.q.glb"
    pack -tr -cc -i "$dir/$name.gltf" -o "$dir/$name.cc.glb"
done
dir="$here/assets/retroufo"
pack -i "$dir/retroufo.glb" -o "$dir/retroufo.q.glb"
pack -cc -i "$dir/retroufo.glb" -o "$dir/retroufo.cc.glb"
# Draco (KHR_draco_mesh_compression) as gltf-pipeline writes it: vergence
# refuses it with the reason (tests/gltf_features.rs).
npx --yes gltf-pipeline@4.3.1 -d -i "$here/assets/Box/Box.gltf" -o "$here/assets/Box/Box.draco.glb" >/dev/null
