#!/usr/bin/env python3
"""Writes the malformed-input corpus in tests/bad_inputs/ and its index
cases.toml (file, how vergence is run on it, what the error must say).
Run from the repository root; the output is committed."""
import base64, json, os, struct, zlib

OUT = "tests/bad_inputs"
cases = []


def case(name, kind, expect, content, mode="w"):
    path = os.path.join(OUT, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if content is not None:
        with open(path, mode) as f:
            f.write(content)
    cases.append((name, kind, expect, None))


def cli(name, args, expect, exit=None, memory=False):
    """A command-line case: vergence ARGS (placeholders: {dir} the corpus,
    {out} a scratch folder, {fifo} a FIFO named pipe.gltf, {fifo_ply} and
    {fifo_las} FIFOs named pipe.ply and pipe.las, {zero_ply} a link
    zero.ply to /dev/zero, {big} a 17 MiB sparse file big.toml; the test
    makes them in its scratch folder); memory: run under an address-space
    limit (no GPU needed)."""
    cases.append((name, "cli", expect, {"args": args, "exit": exit, "memory": memory}))


def tri_bin(pos=None, idx=(0, 1, 2)):
    pos = pos or [0, 0, 0, 1, 0, 0, 0, 1, 0]
    return struct.pack("<9f", *pos) + struct.pack("<3H", *idx) + b"\0\0"


def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def gltf(buf=None, uri=None, byte_length=None, extra=None, prim=None, nodes=None, accessors=None, views=None):
    b = buf if buf is not None else tri_bin()
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri if uri is not None else data_uri(b), "byteLength": byte_length or len(b)}],
        "bufferViews": views or [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 6},
        ],
        "accessors": accessors or [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [prim or {"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": nodes or [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    for k, v in (extra or {}).items():
        doc[k] = v
    return json.dumps(doc, indent=1)


def png(w, h, claim=None, truncate=None):
    raw = b"".join(b"\0" + b"\x80\x80\x80\xff" * w for _ in range(h))
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    cw, ch = claim or (w, h)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cw, ch, 8, 6, 0, 0, 0)) \
        + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    return data[:truncate] if truncate else data


def textured(image_uri):
    b = tri_bin()
    return gltf(extra={
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [{"uri": image_uri}],
    }, prim={"attributes": {"POSITION": 0, "TEXCOORD_0": 0}, "indices": 1, "material": 0},
        accessors=[
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ]).replace('"TEXCOORD_0": 0', '"TEXCOORD_0": 2').replace(
        '"accessors": [', '"accessors": [').replace(
        '"type": "SCALAR"\n  }\n ]', '"type": "SCALAR"\n  },\n  {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}\n ]'
    ).replace('"byteLength": 6\n  }\n ]', '"byteLength": 6\n  },\n  {"buffer": 0, "byteOffset": 0, "byteLength": 24}\n ]')


# --- glTF JSON -------------------------------------------------------------
case("gltf/not-gltf.gltf", "scene", ["not a glTF file"], "hello, I am not a scene\n")
case("gltf/bad-json.gltf", "scene", ["invalid glTF JSON"], '{"asset": {"version": ')
case("gltf/no-asset.gltf", "scene", ["invalid glTF", "asset"], "{}")
case("gltf/required-unknown.gltf", "scene", ["KHR_materials_pbrSpecularGlossiness", "does not support"],
     gltf(extra={"extensionsUsed": ["KHR_materials_pbrSpecularGlossiness"],
                 "extensionsRequired": ["KHR_materials_pbrSpecularGlossiness"]}))
case("gltf/buffer-short.gltf", "scene", ["buffer 0 declares 400 bytes"], gltf(byte_length=400))
case("gltf/view-past-end.gltf", "scene", ["bufferView 1", "runs past the end"],
     gltf(views=[{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                 {"buffer": 0, "byteOffset": 36, "byteLength": 600}]))
case("gltf/accessor-out-of-view.gltf", "scene", ["accessor 0", "out of range of bufferView"],
     gltf(accessors=[{"bufferView": 0, "componentType": 5126, "count": 30, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]))
case("gltf/accessor-offset-overflow.gltf", "scene", ["accessor 0"],
     gltf(accessors=[{"bufferView": 0, "byteOffset": 18446744073709551000, "componentType": 5126,
                      "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]))
case("gltf/index-out-of-range.gltf", "scene", ["index 9 is out of range"], gltf(buf=tri_bin(idx=(0, 1, 9))))
case("gltf/no-position.gltf", "scene", ["POSITION", "Missing"],
     gltf(prim={"attributes": {"NORMAL": 0}, "indices": 1}))
case("gltf/huge-position.gltf", "scene", ["POSITION", "absurd"],
     gltf(buf=tri_bin(pos=[0, 0, 0, 1e20, 0, 0, 0, 1, 0])))
case("gltf/nan-position.gltf", "scene", ["POSITION", "NaN"],
     gltf(buf=tri_bin(pos=[0, 0, 0, float("nan"), 0, 0, 0, 1, 0])))
case("gltf/node-cycle.gltf", "scene", ["reached twice"],
     gltf(nodes=[{"mesh": 0, "children": [1]}, {"children": [0]}]))
deep = [{"children": [i + 1]} for i in range(300)] + [{"mesh": 0}]
case("gltf/deep-nodes.gltf", "scene", ["deeper than 256"], gltf(nodes=deep))
case("gltf/overflowing-scale.gltf", "scene", ["non-finite transform"],
     gltf(nodes=[{"scale": [1e300, 1e300, 1e300], "children": [1]},
                 {"mesh": 0, "scale": [1e300, 1e300, 1e300]}]))
case("gltf/bad-accessor-ref.gltf", "scene", ["attribute POSITION refers to accessor 7"],
     gltf(prim={"attributes": {"POSITION": 7}, "indices": 1}))
# Found by fuzzing (cargo fuzz, gltf_scene): accessor types the gltf
# crate's readers assume and do not check.
case("gltf/fuzz-signed-indices.gltf", "scene", ["indices accessor 1 is I16"],
     gltf(accessors=[{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5122, "count": 3, "type": "SCALAR"}]))
case("gltf/byte-positions.gltf", "scene", ["POSITION accessor 0 is U8"],
     gltf(accessors=[{"bufferView": 0, "componentType": 5121, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]))
case("gltf/fuzz-image-without-source.gltf", "scene", ["image 0 needs a uri"],
     gltf(extra={"images": [{"name": "nothing"}]}))
case("gltf/image-view-without-mime.gltf", "scene", ["image 0 needs a uri"],
     gltf(extra={"images": [{"bufferView": 0}]}))
# Found by review: the gltf readers assert a stride holding whole elements
# and compute count - 1.
case("gltf/small-stride.gltf", "scene", ["byteStride 4 is smaller than its 12-byte elements"],
     gltf(views=[{"buffer": 0, "byteOffset": 0, "byteLength": 36, "byteStride": 4},
                 {"buffer": 0, "byteOffset": 36, "byteLength": 6}]))
case("gltf/zero-count.gltf", "scene", ["accessor 0 has count 0"],
     gltf(accessors=[{"bufferView": 0, "componentType": 5126, "count": 0, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]},
                     {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]))
# Resource URIs.
case("gltf/uri-absolute.gltf", "scene", ["absolute path"], gltf(uri="/etc/passwd", byte_length=42))
case("gltf/uri-parent.gltf", "scene", ["climbs out of the scene folder"], gltf(uri="../../Cargo.toml", byte_length=42))
case("gltf/uri-encoded-parent.gltf", "scene", ["climbs out"], gltf(uri="%2e%2e/%2e%2e/Cargo.toml", byte_length=42))
case("gltf/uri-http.gltf", "scene", ["has a scheme"], gltf(uri="http://example.com/tri.bin", byte_length=42))
case("gltf/uri-file.gltf", "scene", ["has a scheme"], gltf(uri="file:///etc/passwd", byte_length=42))
case("gltf/uri-symlink.gltf", "scene", ["outside the scene folder"], gltf(uri="outside.bin", byte_length=42))
link = os.path.join(OUT, "gltf/outside.bin")
if not os.path.islink(link):
    os.symlink("../../../Cargo.toml", link)
case("gltf/uri-missing.gltf", "scene", ["buffer 0", "nothing-here.bin"], gltf(uri="nothing-here.bin", byte_length=42))
case("gltf/data-not-base64.gltf", "scene", ["not base64-encoded"], gltf(uri="data:text/plain,hello", byte_length=5))
case("gltf/data-bad-base64.gltf", "scene", ["invalid base64"],
     gltf(uri="data:application/octet-stream;base64,@@@@", byte_length=3))
# Images.
case("images/missing-image.gltf", "scene", ["image 0", "nope.png"], textured("nope.png"))
case("images/garbage-image.gltf", "scene", ["garbage.png", "cannot be decoded"], textured("garbage.png"))
case("images/garbage.png", None, None, b"\x89PNG but not really" * 4, "wb")
case("images/bomb-image.gltf", "scene", ["bomb.png", "over the limits"], textured("bomb.png"))
case("images/bomb.png", None, None, png(1, 1, claim=(100000, 100000)), "wb")
case("images/truncated-image.gltf", "scene", ["truncated.png", "cannot be decoded"], textured("truncated.png"))
case("images/truncated.png", None, None, png(8, 8, truncate=45), "wb")
case("images/zero-size-image.gltf", "scene", ["zero.png", "cannot be decoded"], textured("zero.png"))
case("images/zero.png", None, None, png(1, 1, claim=(0, 0)), "wb")
# --- glTF extensions and newer paths (issue 15) -----------------------------
def ext_gltf(used, required=None, **kw):
    doc = json.loads(gltf(**kw))
    doc["extensionsUsed"] = used
    if required:
        doc["extensionsRequired"] = required
    return doc

MO = "EXT_meshopt_compression"
def meshopt(view_ext, stream=b"\xa0" + b"\x00" * 40, view_stride=12, drop=()):
    b = tri_bin() + stream
    doc = ext_gltf([MO], [MO], buf=b)
    doc["buffers"].append({"byteLength": 36, "extensions": {MO: {"fallback": True}}})
    doc["bufferViews"][0] = {"buffer": 1, "byteOffset": 0, "byteLength": 36, "byteStride": view_stride,
                             "extensions": {MO: dict({"buffer": 0, "byteOffset": 44,
                                                      "byteLength": len(stream), "byteStride": 12,
                                                      "count": 3, "mode": "ATTRIBUTES"}, **view_ext)}}
    for key in drop:
        del doc["bufferViews"][0]["extensions"][MO][key]
    if view_stride is None:
        del doc["bufferViews"][0]["byteStride"]
    return json.dumps(doc, indent=1)
case("gltf/meshopt-stream-past-buffer.gltf", "scene", ["bufferView 0", "meshopt", "longer than buffer 0"],
     meshopt({"byteLength": 100000}))
case("gltf/meshopt-filter-on-triangles.gltf", "scene", ["bufferView 0", "filter OCTAHEDRAL is only allowed with ATTRIBUTES"],
     meshopt({"mode": "TRIANGLES", "filter": "OCTAHEDRAL", "byteStride": 2, "count": 18}, view_stride=None))
case("gltf/meshopt-quaternion-stride.gltf", "scene", ["filter QUATERNION does not allow byteStride 12"],
     meshopt({"filter": "QUATERNION"}))
case("gltf/meshopt-unknown-mode.gltf", "scene", ["unknown mode 'STRIPS'"], meshopt({"mode": "STRIPS"}))
case("gltf/meshopt-garbage-stream.gltf", "scene", ["bufferView 0", "does not decode"], meshopt({}))
case("gltf/meshopt-missing-count.gltf", "scene", ["meshopt compression has no count"],
     meshopt({}, drop=["count"]))
# A 41-byte stream claiming 100 M vertices of 12 bytes (1.2 GB decoded).
case("gltf/meshopt-count-bomb.gltf", "scene", ["bufferView 0", "more than 64 per stream byte"],
     meshopt({"count": 100_000_000}))
doc = json.loads(meshopt({}))
del doc["bufferViews"][0]["extensions"]
case("gltf/meshopt-plain-view-in-fallback.gltf", "scene", ["bufferView 0", "fallback buffer, but is not compressed"],
     json.dumps(doc, indent=1))
# KHR_mesh_quantization: normals must be normalized signed integers.
qbin = struct.pack("<9b", 0, 0, 127, 0, 0, 127, 0, 0, 127) + b"\0" * 3
doc = ext_gltf(["KHR_mesh_quantization"], ["KHR_mesh_quantization"], buf=tri_bin() + qbin)
doc["bufferViews"].append({"buffer": 0, "byteOffset": 44, "byteLength": 12, "byteStride": 4})
doc["accessors"].append({"bufferView": 2, "componentType": 5120, "count": 3, "type": "VEC3"})
doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2
case("gltf/quantized-normal-not-normalized.gltf", "scene", ["NORMAL accessor 2 is I8", "normalized signed byte or short"],
     json.dumps(doc, indent=1))
# Sparse accessors: indices out of range, values past their view.
def sparse(count, idx_bytes, values_offset=0):
    b = tri_bin() + idx_bytes + b"\0" * (-len(idx_bytes) % 4)
    doc = json.loads(gltf(buf=b))
    doc["bufferViews"].append({"buffer": 0, "byteOffset": 44, "byteLength": len(idx_bytes)})
    doc["accessors"][0]["sparse"] = {"count": count, "indices": {"bufferView": 2, "componentType": 5123},
                                     "values": {"bufferView": 0, "byteOffset": values_offset}}
    return json.dumps(doc, indent=1)
case("gltf/sparse-index-out-of-range.gltf", "scene", ["accessor 0", "sparse index 7 is out of range"],
     sparse(1, struct.pack("<H", 7)))
case("gltf/sparse-values-past-view.gltf", "scene", ["accessor 0", "sparse values at offset 30 run past bufferView 0"],
     sparse(1, struct.pack("<H", 1), values_offset=30))
case("gltf/sparse-too-many.gltf", "scene", ["accessor 0", "4 sparse values for 3 elements"],
     sparse(4, struct.pack("<4H", 0, 1, 2, 2)))
# KHR_draco_mesh_compression: a Draco bufferView that is no Draco stream,
# an extension object without its bufferView, and gltf-pipeline's own
# output made hostile (below, after the GLB helper).
doc = json.loads(gltf())
doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
prim = doc["meshes"][0]["primitives"][0]
doc["accessors"][0].pop("bufferView")
prim["extensions"] = {"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}}
case("gltf/draco-not-a-stream.gltf", "scene", ["KHR_draco_mesh_compression", "Draco stream cannot be decoded"],
     json.dumps(doc, indent=1))
doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
prim["extensions"]["KHR_draco_mesh_compression"].pop("bufferView")
case("gltf/draco-no-bufferview.gltf", "scene", ["mesh 0 primitive 0", "KHR_draco_mesh_compression: bufferView is missing"],
     json.dumps(doc, indent=1))
# KHR_texture_transform, emissive strength, lights.
def material_case(material, extra_ext=None):
    doc = json.loads(textured("tiny.png"))
    doc["materials"][0].update(material)
    doc["extensionsUsed"] = ["KHR_texture_transform", "KHR_materials_emissive_strength"]
    return json.dumps(doc, indent=1)
case("images/tiny.png", None, None, png(2, 2), "wb")
case("images/transform-bad-rotation.gltf", "scene", ["base colour texture", "KHR_texture_transform rotation \"x\" is not a finite number"],
     material_case({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"rotation": "x"}}}}}))
case("images/transform-bad-texcoord.gltf", "scene", ["KHR_texture_transform texCoord 5"],
     material_case({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"texCoord": 5}}}}}))
case("images/transform-short-offset.gltf", "scene", ["KHR_texture_transform offset [0.5] is not two finite numbers"],
     material_case({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5]}}}}}))
case("images/emissive-strength-negative.gltf", "scene", ["material 0", "emissiveStrength -2.0 is not a number"],
     material_case({"extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": -2.0}}}))
doc = json.loads(gltf())
doc["extensionsUsed"] = ["KHR_lights_punctual"]
doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "directional"}]}}
doc["nodes"].append({"extensions": {"KHR_lights_punctual": {"light": 3}}})
doc["scenes"][0]["nodes"].append(1)
case("gltf/light-missing.gltf", "scene", ["node 1", "light 3 does not exist"], json.dumps(doc, indent=1))
doc["extensions"]["KHR_lights_punctual"]["lights"][0] = {"type": "laser"}
case("gltf/light-unknown-type.gltf", "scene", ["light 0", "unknown type 'laser'"], json.dumps(doc, indent=1))
doc["extensions"]["KHR_lights_punctual"]["lights"][0] = {"type": "directional", "intensity": -1}
case("gltf/light-negative-intensity.gltf", "scene", ["light 0", "intensity -1 is not a number"], json.dumps(doc, indent=1))
# KHR_texture_basisu (KTX2) and EXT_texture_webp images.
def ktx2(w=2, h=2, fmt=37, scheme=0, level_offset=None, cut=None, texels=None):
    px = b"\x80\x40\x20\xff" * (texels if texels is not None else w * h)
    dfd = struct.pack("<I", 92) + struct.pack("<II", 0, 2 | (88 << 16)) + bytes([1, 1, 1, 0, 0, 0, 0, 0]) \
        + bytes([4, 0, 0, 0, 0, 0, 0, 0])
    for c, off in ((0, 0), (1, 8), (2, 16), (15, 24)):
        dfd += struct.pack("<HBB4sII", off, 7, c, b"\0\0\0\0", 0, 255)
    start = 80 + 24 + len(dfd)
    head = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A]) \
        + struct.pack("<9I", fmt, 1, w, h, 0, 0, 1, 1, scheme) \
        + struct.pack("<4I2Q", 104, len(dfd), 0, 0, 0, 0) \
        + struct.pack("<3Q", level_offset if level_offset is not None else start, len(px), len(px))
    data = head + dfd + px
    return data[:cut] if cut else data
def ktx2_case(name, expect, data):
    doc = json.loads(textured(name))
    doc["extensionsUsed"] = ["KHR_texture_basisu"]
    doc["extensionsRequired"] = ["KHR_texture_basisu"]
    doc["images"][0]["mimeType"] = "image/ktx2"
    doc["textures"][0] = {"extensions": {"KHR_texture_basisu": {"source": 0}}}
    case("images/" + name.replace(".ktx2", ".gltf"), "scene", [name] + expect, json.dumps(doc, indent=1))
    case("images/" + name, None, None, data, "wb")
ktx2_case("ktx2-bad-level.ktx2", ["invalid KTX2 container"], ktx2(level_offset=1 << 40))
ktx2_case("ktx2-truncated.ktx2", ["invalid KTX2 container"], ktx2(cut=90))
# Found by fuzzing (gltf_decoders): ktx2 0.5 adds one to a 255 texel block
# dimension in a u8 and unwraps it as non-zero.
dims = bytearray(ktx2())
dims[108 + 12] = 255
ktx2_case("ktx2-block-dimension.ktx2", ["texel block dimension of 256"], bytes(dims))
ktx2_case("ktx2-etc1s.ktx2", ["Basis Universal payload cannot be"], ktx2(fmt=0, scheme=1))
ktx2_case("ktx2-uastc.ktx2", ["Basis Universal payload cannot be"], ktx2(fmt=0))
# The basisu encoder's real output (assets/BoxTextured), damaged.
with open("assets/BoxTextured/CesiumLogoFlat.etc1s.ktx2", "rb") as f:
    etc1s = f.read()
with open("assets/BoxTextured/CesiumLogoFlat.uastc.ktx2", "rb") as f:
    uastc = f.read()
ktx2_case("ktx2-etc1s-truncated.ktx2", ["invalid KTX2 container"], etc1s[:len(etc1s) // 2])
ktx2_case("ktx2-etc1s-garbled.ktx2", ["Basis Universal payload cannot be"],
          etc1s[:-600] + bytes(b ^ 0x5A for b in etc1s[-600:]))
ktx2_case("ktx2-uastc-garbled-zstd.ktx2", ["Basis Universal payload cannot be"],
          uastc[:-2000] + bytes(b ^ 0x5A for b in uastc[-2000:]))
ktx2_case("ktx2-etc1s-wrong-size.ktx2", ["KTX2"],
          etc1s[:20] + struct.pack("<II", 4096, 4096) + etc1s[28:])
ktx2_case("ktx2-short-level.ktx2", ["KTX2 level 0 holds 16 bytes, but 4x4 RGBA8 needs 64"],
          ktx2(w=4, h=4, texels=4))
# Found by mutation fuzzing (tests/fuzz_mutate.rs): the transcoder walks
# the key/value entries with unchecked arithmetic, and an entry whose
# padding runs past the data's end underflowed it. kvdByteOffset and
# kvdByteLength are at bytes 56..64: the data made one byte shorter and its
# first entry as long as the rest less one byte.
def kvd_padding_past_end(data):
    start, length = struct.unpack("<II", data[56:64])
    length -= 1
    entry = length - 4 - 1
    out = bytearray(data)
    out[56:64] = struct.pack("<II", start, length)
    out[start:start + 4] = struct.pack("<I", entry)
    return bytes(out)
ktx2_case("ktx2-kvd-padding-past-end.ktx2", ["padding runs past the data's end"], kvd_padding_past_end(etc1s))
# Found by mutation fuzzing (tests/fuzz_mutate.rs): the transcoder
# allocated a level's declared uncompressed length (here 32 GiB) before
# inflating it. Level 0's uncompressedByteLength is at bytes 96..104.
def lying_level(data, n):
    return data[:96] + struct.pack("<Q", n) + data[104:]
ktx2_case("ktx2-uastc-level-length-lie.ktx2", ["level 0 declares 34359738368 uncompressed bytes"],
          lying_level(uastc, 1 << 35))
ktx2_case("ktx2-uastc-level-length-max.ktx2", ["level 0 declares 18446744073709551615 uncompressed bytes"],
          lying_level(uastc, (1 << 64) - 1))
doc = json.loads(textured("garbage.webp"))
doc["extensionsUsed"] = ["EXT_texture_webp"]
doc["images"][0]["mimeType"] = "image/webp"
doc["textures"][0] = {"extensions": {"EXT_texture_webp": {"source": 0}}}
case("images/webp-garbage.gltf", "scene", ["garbage.webp", "cannot be decoded"], json.dumps(doc, indent=1))
case("images/garbage.webp", None, None, b"RIFF\x20\x00\x00\x00WEBPVP8 " + b"\x07" * 24, "wb")
doc["textures"][0] = {"extensions": {"EXT_texture_webp": {"source": 9}}}
case("images/webp-missing-source.gltf", "scene", ["texture 0 refers to image 9, but there are 1"], json.dumps(doc, indent=1))
# --- GLB -------------------------------------------------------------------
good_json = gltf(uri="").replace('"uri": "",', "").encode()
def glb(json_bytes, bin_bytes=None, version=2, cut=None):
    j = json_bytes + b" " * (-len(json_bytes) % 4)
    body = struct.pack("<I4s", len(j), b"JSON") + j
    if bin_bytes is not None:
        bb = bin_bytes + b"\0" * (-len(bin_bytes) % 4)
        body += struct.pack("<I4s", len(bb), b"BIN\0") + bb
    data = struct.pack("<4sII", b"glTF", version, 12 + len(body)) + body
    return data[:cut] if cut else data
case("glb/truncated.glb", "scene", ["malformed or truncated .glb container", "could not completely read"], glb(good_json, tri_bin(), cut=60), "wb")
case("glb/version-1.glb", "scene", ["unsupported version"], glb(good_json, tri_bin(), version=1), "wb")
case("glb/missing-bin.glb", "scene", ["GLB binary chunk, which is missing"], glb(good_json), "wb")
# Found by fuzzing (gltf_scene): gltf 1.4.1 subtracts the header from the
# declared length unchecked.
case("glb/short-length.glb", "scene", ["declared length 4 is shorter than its 12-byte header"],
     struct.pack("<4sII", b"glTF", 2, 4) + glb(good_json, tri_bin())[12:], "wb")
case("glb/bad-length.glb", "scene", ["malformed or truncated .glb container"],
     struct.pack("<4sII", b"glTF", 2, 0xFFFFFFF0) + glb(good_json, tri_bin())[12:], "wb")
# --- HMD profiles --------------------------------------------------------------
VIEW = '[[views]]\nposition = [{x}, 0.0, 0.0]\norientation = [0.0, 0.0, 0.0, 1.0]\nfov = {{ left = {l}, right = 0.8, up = 0.8, down = -0.8 }}\nresolution = [{w}, 480]\n'
def hmd(l="-0.8", w="640", extra="", views=2, refresh="90.0"):
    s = f'name = "bad"\nrefresh_hz = {refresh}\n' + extra
    for i in range(views):
        s += VIEW.format(x=-0.03 if i == 0 else 0.03, l=l, w=w)
    return s
case("hmd/nan-fov.toml", "hmd", ["fov.left = NaN is not an angle"], hmd(l="nan"))
case("hmd/inverted-fov.toml", "hmd", ["fov.right (0.8) must be greater than fov.left (1.2)"], hmd(l="1.2"))
case("hmd/zero-resolution.toml", "hmd", ["resolution 0x480 must be within"], hmd(w="0"))
case("hmd/unknown-key.toml", "hmd", ["unknown field `lens`"], hmd(extra="lens = 3\n"))
case("hmd/one-view.toml", "hmd", ["needs exactly 2 views"], hmd(views=1))
case("hmd/zero-refresh.toml", "hmd", ["refresh_hz = 0 must be in"], hmd(refresh="0.0"))
case("hmd/hidden-area-not-triangles.toml", "hmd", ["hidden_area has 2 points; it is a triangle list"],
     hmd().replace("resolution = [640, 480]\n", "resolution = [640, 480]\nhidden_area = [[0.0, 0.0], [0.1, 0.0]]\n", 1))
# Lens tables (the distortion preview's [views.lens]).
LENS = '[views.lens]\nmodel = "{model}"\nk = {k}\nchroma = [0.99, 1.0, 1.01]\ncentre = [0.5, 0.5]\nunit = [0.5, 0.5]\ntangent = [1.0, 1.0]\n{extra}'
def lens_hmd(model="panotools", k="[0.0, 0.0, 0.0, 1.0]", extra=""):
    return hmd().replace("resolution = [640, 480]\n", "resolution = [640, 480]\n" + LENS.format(model=model, k=k, extra=extra))
case("hmd/lens-folds.toml", "hmd", ["views[0].lens", "does not increase"], lens_hmd(k="[1.0, -3.0, 0.4, 0.6]"))
case("hmd/lens-nan.toml", "hmd", ["views[0].lens", "not finite"], lens_hmd(k="[nan, 0.0, 0.0, 1.0]"))
case("hmd/lens-unknown-model.toml", "hmd", ['unknown model "fisheye"'], lens_hmd(model="fisheye"))
case("hmd/lens-wrong-key.toml", "hmd", ["`red` does not belong"], lens_hmd(extra="red = [0.0, 0.0, 0.0, 0.0]\n"))
case("hmd/lens-short-k.toml", "hmd", ["expected an array of 4 numbers"], lens_hmd(k="[0.0, 1.0]"))
case("hmd/lens-zero-unit.toml", "hmd", ["must be positive"], lens_hmd().replace("unit = [0.5, 0.5]", "unit = [0.0, 0.5]"))
case("hmd/lens-huge-rmax.toml", "hmd", ["r_max", "must be in (0, 1000]"], lens_hmd(extra="r_max = 1e300\n"))
# --- Scene manifests -----------------------------------------------------------
case("manifests/empty.toml", "scene", ["no [[gltf]], [[procedural]] or [[points]]"], 'name = "x"\n')
case("manifests/zero-scale.toml", "scene", ["scale 0 must be a number in [1e-6, 1e6]"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 10\nscale = 0.0\n')
case("manifests/grid-bomb.toml", "scene", ["instance limit"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 1000\ngrid = { count = [1000, 100, 100], spacing = [1.0, 1.0, 1.0] }\n')
case("manifests/unknown-kind.toml", "scene", ["unknown kind 'castle'"],
     'name = "x"\n[[procedural]]\nkind = "castle"\ninstances = 10\n')
case("manifests/missing-gltf.toml", "scene", ["no-such-model.glb"],
     'name = "x"\n[[gltf]]\nfile = "no-such-model.glb"\n')
case("manifests/typo.toml", "scene", ["malformed scene manifest", "translaton"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 10\ntranslaton = [0.0, 0.0, 0.0]\n')
MOVING = 'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 10\nmotion = {motion}\n'
case("manifests/motion-nan-spin.toml", "scene", ["procedural[0]", "spin_deg_s = NaN"],
     MOVING.format(motion="{ spin_deg_s = nan }"))
case("manifests/motion-zero-period.toml", "scene", ["procedural[0]", "bob_period_s = 0"],
     MOVING.format(motion="{ bob_m = 1.0, bob_period_s = 0.0 }"))
case("manifests/motion-huge-bob.toml", "scene", ["procedural[0]", "bob_m = 1e300"],
     MOVING.format(motion="{ bob_m = 1e300 }"))
case("manifests/motion-unknown-key.toml", "scene", ["malformed scene manifest", "spin_rpm"],
     MOVING.format(motion="{ spin_rpm = 3.0 }"))
# --- Bench plans and config files ---------------------------------------------
PLAN = 'name = "p"\nscenes = ["factory:10"]\nhmds = ["monado-sim"]\nframes = {frames}\n[[configs]]\nname = "a"\nopt = "{opt}"\n'
case("plans/bad-opt.toml", "plan", ["hyperdrive"], PLAN.format(frames=2, opt="hyperdrive"))
case("plans/zero-frames.toml", "plan", ["frames = 0"], PLAN.format(frames=0, opt="two-pass"))
case("plans/one-flicker-frame.toml", "plan", ["flicker_frames = 1", "0 (off) or 2 to 120"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\nflicker_frames = 1\n", 1))
case("plans/reference-supersample-5.toml", "plan", ["reference_supersample = 5", "1 to 4"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\nreference_supersample = 5\n", 1))
case("plans/reference-supersample-aq.toml", "plan", ["reference_supersample = 2", "leave aq out"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\nreference_supersample = 2\nreference = \"multiview,aq\"\n", 1))
case("plans/path-seeds-repeated.toml", "plan", ["path_seeds repeats a seed"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\npath_seeds = [3, 3]\n", 1))
case("plans/path-seeds-nine.toml", "plan", ["path_seeds has 9 seeds", "at most 8"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\npath_seeds = [1, 2, 3, 4, 5, 6, 7, 8, 9]\n", 1))
case("plans/gaze-unknown.toml", "plan", ["gaze", "saccades"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\ngaze = \"wander\"\n", 1))
case("plans/gaze-latency-huge.toml", "plan", ["gaze_latency_ms = 900", "0 to 500"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\ngaze_latency_ms = 900\n", 1))
case("plans/repeats-zero.toml", "plan", ["repeats = 0", "1 to 10"],
     PLAN.format(frames=2, opt="two-pass").replace("frames = 2\n", "frames = 2\nrepeats = 0\n", 1))
case("plans/duplicate-names.toml", "plan", ["appears twice"],
     PLAN.format(frames=2, opt="two-pass") + '[[configs]]\nname = "a"\nopt = "multiview"\n')
case("configs/unknown-key.toml", "config", ["colour"], 'opt = "multiview"\ncolour = 3\n')
case("configs/bad-opt.toml", "config", ["warp"], 'opt = "multiview,warp"\n')

# --- Hardening round 2 (issue 18) ------------------------------------------
# Class 1, unbounded reads: devices, FIFOs, folders and oversized files are
# refused before reading. {fifo}, {big} and {out} are made by the runner.
cli("read-dev-zero", ["inspect", "/dev/zero"], ["/dev/zero", "a character device, not a regular file"], memory=True)
cli("read-dev-urandom", ["inspect", "/dev/urandom"], ["/dev/urandom", "a character device"], memory=True)
cli("read-fifo-scene", ["inspect", "{fifo}"], ["pipe.gltf", "a FIFO, not a regular file"], memory=True)
cli("read-folder-scene", ["inspect", "{dir}/gltf"], ["a directory, not a regular file"], memory=True)
cli("read-hmd-dev-zero", ["render", "--hmd", "/dev/zero", "--out", "{out}"], ["HMD profile /dev/zero", "a character device"], memory=True)
cli("read-rig-dev-zero", ["render", "--rig", "/dev/zero", "--out", "{out}"], ["/dev/zero", "a character device"], memory=True)
cli("read-config-fifo", ["render", "--config", "{fifo}", "--out", "{out}"], ["pipe.gltf", "a FIFO"], memory=True)
cli("read-plan-dev-zero", ["bench", "--plan", "/dev/zero", "--out", "{out}"], ["/dev/zero", "a character device"], memory=True)
cli("read-big-profile", ["render", "--hmd", "{big}", "--out", "{out}"], ["big.toml", "over the 16777216-byte limit"], memory=True)
cli("read-compare-dev-zero", ["compare", "/dev/zero", "/dev/zero"], ["/dev/zero", "a character device"], memory=True)
case("manifests/gltf-dev-zero.toml", "scene", ["/dev/zero", "a character device"],
     'name = "x"\n[[gltf]]\nfile = "/dev/zero"\n')
# Class 2, count overflow: grid products that wrap u64 are errors, checked
# before anything is allocated.
case("manifests/grid-wraps.toml", "scene", ["procedural[0]", "overflows a 64-bit count"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 1\ngrid = { count = [2147483648, 2147483648, 4], spacing = [0.0, 0.0, 0.0] }\n')
case("manifests/grid-max.toml", "scene", ["procedural[0]", "overflows a 64-bit count"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 1\ngrid = { count = [4294967295, 4294967295, 4294967295], spacing = [0.0, 0.0, 0.0] }\n')
case("manifests/grid-wraps-gltf.toml", "scene", ["gltf[0]", "over the limit of 20000000"],
     'name = "x"\n[[gltf]]\nfile = "../gltf/index-out-of-range.gltf"\ngrid = { count = [65536, 65536, 4294967295], spacing = [0.0, 0.0, 0.0] }\n')
case("manifests/instances-times-cells.toml", "scene", ["procedural[0]", "instance limit"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 50000000\ngrid = { count = [20000000, 1, 1], spacing = [0.0, 0.0, 0.0] }\n')
# Class 4, CLI values outside their documented bounds.
cli("cli-run-seconds-1e20", ["run", "--seconds", "1e20"], ["--seconds", "(0, 1000000]"], exit=2)
cli("cli-run-seconds-nan", ["run", "--seconds", "NaN"], ["--seconds"], exit=2)
cli("cli-run-frames-0", ["run", "--frames", "0"], ["--frames", "1..=1000000000"], exit=2)
cli("cli-cull-frames-max", ["cull-bench", "--frames", "18446744073709551615"], ["--frames", "1..=1000000"], exit=2)
cli("cli-cull-frames-1e12", ["cull-bench", "--frames", "1000000000000"], ["--frames", "1..=1000000"], exit=2)
cli("cli-cull-threads", ["cull-bench", "--threads", "10000"], ["--threads", "1..=64"], exit=2)
cli("cli-floors-samples", ["raster-floors", "--samples", "3"], ["--samples", "not 2, 4 or 8"], exit=2)
cli("cli-floors-width", ["raster-floors", "--width", "0"], ["--width", "16..=8192"], exit=2)
cli("cli-floors-repeats", ["raster-floors", "--repeats", "100000"], ["--repeats", "1..=1000"], exit=2)
cli("cli-floors-views", ["raster-floors", "--views", "3"], ["--views", "1..=2"], exit=2)
cli("cli-cull-leaf-size", ["cull-bench", "--leaf-size", "0"], ["--leaf-size"], exit=2)
cli("cli-cull-near", ["cull-bench", "--near=-1"], ["--near"], exit=2)
cli("cli-render-width", ["render", "--width", "100000", "--height", "10", "--out", "{out}"], ["--width", "1..=16384"], exit=2)
cli("cli-render-pose", ["render", "--pose", "1e300,0,0,0,0,0", "--out", "{out}"], ["--pose", "within"], exit=2)
cli("cli-render-section", ["render", "--section", "0,0,0,0,0,0", "--out", "{out}"], ["--section", "no direction"], exit=2)
cli("cli-tune-budget", ["tune", "--budget-ms", "inf"], ["--budget-ms"], exit=2)
cli("cli-tune-flicker-cap", ["tune", "--budget-ms", "10", "--max-flicker", "base"], ["--max-flicker", "or baseline"], exit=2)
cli("cli-tune-reference-supersample", ["tune", "--budget-ms", "10", "--reference-supersample", "5"], ["--reference-supersample"], exit=2)
cli("cli-compare-ppd", ["compare", "a.png", "b.png", "--ppd", "1e9"], ["--ppd"], exit=2)
# Class 5, dead or silently ignored options: used, or refused.
cli("cli-lens-nan", ["cull-bench", "--lens-half-angle", "NaN"], ["--lens-half-angle", "(0, π/2)"], exit=2)
cli("cli-lens-too-wide", ["cull-bench", "--lens-half-angle", "2"], ["--lens-half-angle"], exit=2)
cli("opt-conflict-stereo", ["render", "--opt", "multiview,two-pass", "--out", "{out}"], ["--opt", "'two-pass' conflicts with 'multiview'", "stereo mode"])
cli("opt-conflict-foveation", ["render", "--opt", "foveation=low,foveation=high", "--out", "{out}"], ["--opt", "foveation level"])
cli("opt-conflict-cull", ["render", "--opt", "per-eye,superfrustum", "--out", "{out}"], ["--opt", "culling strategy"])
case("configs/conflicting-msaa.toml", "config", ["'no-msaa' conflicts with 'msaa4'"], 'opt = "msaa4,no-msaa"\n')
RIG_HEAD = '"head": {"position": [0, 1.7, 0], "orientation": [0, 0, 0, 1]}'
RIG_VIEW = '{"pose": {"position": [%s, 1.7, 0], "orientation": [0, 0, 0, 1]}, "fov": {"left": -0.8, "right": 0.8, "up": 0.8, "down": -0.8}%s}'
def rig(extra_top="", view_extra="", views=None):
    vs = views if views is not None else [RIG_VIEW % ("-0.03", view_extra), RIG_VIEW % ("0.03", view_extra)]
    return "{" + RIG_HEAD + ', "views": [' + ", ".join(vs) + "]" + extra_top + "}\n"
case("rigs/unknown-key.json", "rig", ["not a rig file", "unknown field `extra`"], rig(extra_top=', "extra": 1'))
case("rigs/unknown-view-key.json", "rig", ["unknown field `colour`"], rig(view_extra=', "colour": 3'))
case("rigs/unknown-fov-key.json", "rig", ["unknown field `near`"],
     rig(views=[(RIG_VIEW % ("0", "")).replace('"down": -0.8', '"down": -0.8, "near": 0.1')]))
# Class 6, exact array shapes in profiles and rigs.
case("hmd/orientation-five.toml", "hmd", ["malformed profile", "invalid type: string"],
     hmd().replace("orientation = [0.0, 0.0, 0.0, 1.0]", 'orientation = [0, 0, 0, 1, "x"]', 1))
case("hmd/orientation-extra-number.toml", "hmd", ["expected an array of 4 numbers, found 5 elements"],
     hmd().replace("orientation = [0.0, 0.0, 0.0, 1.0]", "orientation = [0.0, 0.0, 0.0, 1.0, 0.0]", 1))
case("hmd/position-four.toml", "hmd", ["expected an array of 3 numbers, found 4 elements"],
     hmd().replace("position = [-0.03, 0.0, 0.0]", "position = [-0.03, 0.0, 0.0, 9.0]", 1))
case("hmd/resolution-three.toml", "hmd", ["expected an array of 2 numbers, found 3 elements"],
     hmd().replace("resolution = [640, 480]", "resolution = [640, 480, 3]", 1))
case("hmd/hidden-area-point-three.toml", "hmd", ["point 1 has 3 numbers"],
     hmd().replace("resolution = [640, 480]\n", "resolution = [640, 480]\nhidden_area = [[0.0, 0.0], [0.1, 0.0, 0.5], [0.0, 0.1]]\n", 1))
case("rigs/position-four.json", "rig", ["expected an array of 3 numbers, found 4 elements"],
     rig().replace('"position": [0, 1.7, 0]', '"position": [0, 1.7, 0, 1]'))
# Class 7, rig hidden areas: what a rig file may carry.
case("rigs/hidden-area-one-view.json", "rig", ["every view has a hidden_area or none"],
     rig(views=[RIG_VIEW % ("-0.03", ', "hidden_area": [[0, 0], [0.1, 0], [0, 0.1]]'), RIG_VIEW % ("0.03", "")]))
case("rigs/hidden-area-not-triangles.json", "rig", ["view 0: hidden_area has 2 points"],
     rig(view_extra=', "hidden_area": [[0, 0], [0.1, 0]]'))
case("rigs/no-views.json", "rig", ["needs 1 to 4 views, found 0"], rig(views=[]))
# Class 8, never write over an input (the heat map).
cli("compare-heatmap-over-reference", ["compare", "{dir}/images/t.flip.png", "{dir}/images/t.png"],
    ["t.flip.png", "never writes over an input"], memory=True)
cli("compare-heatmap-is-test", ["compare", "{dir}/images/t.flip.png", "{dir}/images/t.png", "--heatmap", "{dir}/images/t.png"],
    ["t.png", "never writes over an input"], memory=True)
cli("compare-heatmap-is-folder", ["compare", "{dir}/images/t.flip.png", "{dir}/images/t.png", "--heatmap", "{dir}/images"],
    ["images", "is a directory"], memory=True)
case("images/t.png", None, None, png(4, 4), "wb")
case("images/t.flip.png", None, None, png(4, 4), "wb")
# Class 11, errors that name their cause.
case("manifests/procedural-zero.toml", "scene", ["procedural[0]: instances = 0 must be within"],
     'name = "x"\n[[procedural]]\nkind = "factory"\ninstances = 0\n')
case("hmd/narrow.toml", None, None, hmd(l="-0.005").replace("right = 0.8", "right = 0.005").replace("640", "4096").replace("480]", "4096]"))
case("plans/narrow-fov.toml", "plan", ["HMD profile", "narrow.toml", "pixels per degree", "2^34"],
     PLAN.format(frames=2, opt="two-pass").replace('hmds = ["monado-sim"]', 'hmds = ["tests/bad_inputs/hmd/narrow.toml"]'))
# Class 12, the whole plan and every output name checked up front.
case("plans/second-scene-missing.toml", "plan", ["scene no-such-scene.glb", "no such file"],
     PLAN.format(frames=2, opt="two-pass").replace('scenes = ["factory:10"]', 'scenes = ["factory:10", "no-such-scene.glb"]'))
case("plans/tiny-scale.toml", "plan", ["scale 0.000000001 gives 0x0 px per eye"],
     PLAN.format(frames=2, opt="two-pass") .replace("frames = 2\n", "frames = 2\nscales = [1.0, 1e-9]\n"))
case("plans/long-name.toml", "plan", ["must be at most 64 characters"],
     PLAN.format(frames=2, opt="two-pass").replace('name = "a"', 'name = "' + "n" * 300 + '"'))
case("plans/bad-factory.toml", "plan", ["scene factory:0", "1..=50000000"],
     PLAN.format(frames=2, opt="two-pass").replace('scenes = ["factory:10"]', 'scenes = ["factory:10", "factory:0"]'))
case("plans/long-scene-path.toml", "plan", ["the image folder name would be", "over 200"],
     PLAN.format(frames=2, opt="two-pass").replace('scenes = ["factory:10"]', 'scenes = ["factory:10", "tests/bad_inputs/' + "d/" * 0 + "cases.toml" + "/." * 0 + '"]').replace("tests/bad_inputs/cases.toml", "tests/bad_inputs/./" + "./" * 100 + "cases.toml"))
cli("cull-strategies-twice", ["cull-bench", "--strategies", "per-eye,per-eye", "--frames", "1", "--instances", "10"], ["--strategies lists per-eye twice"])
cli("tune-out-is-its-folder", ["tune", "--budget-ms", "10", "--out", "{out}/X.bench"], ["--out", "both the config file and its measurement folder"])
cli("bench-out-is-a-file", ["bench", "--plan", "smoke", "--out", "{dir}/cases.toml"], ["--out", "is a file"])
# Class 13, minor.
cli("opt-mffr-tiny", ["render", "--opt", "mffr=1e-46", "--out", "{out}"], ["mffr=1e-46", "[0.1, 1000000]"])
case("configs/mffr-tiny.toml", "config", ["mffr=1e-46"], 'opt = "mffr=1e-46"\n')
case("hmd/refresh-tiny.toml", "hmd", ["refresh_hz = 1e-300 must be in [1, 1000]"], hmd(refresh="1e-300"))
case("plans/newline-name.toml", "plan", ["without control characters"],
     PLAN.format(frames=2, opt="two-pass").replace('name = "a"', 'name = "a\\nb"'))
case("glb/header-shorter.glb", "scene", ["header declares", "bytes but the file has"],
     glb(good_json, tri_bin()) + b"trailing bytes past the declared length", "wb")

# KHR_draco_mesh_compression: gltf-pipeline's Box.draco.glb made hostile.
with open("assets/Box/Box.draco.glb", "rb") as f:
    box = f.read()
box_jl = struct.unpack("<I", box[12:16])[0]
box_bl = struct.unpack("<I", box[20 + box_jl:24 + box_jl])[0]
box_bin = box[28 + box_jl:28 + box_jl + box_bl]


def draco_box(edit=None, stream=None):
    """Box.draco.glb with its JSON edited and/or its Draco stream (bufferView
    0, 118 bytes at the start of the binary chunk) replaced."""
    doc = json.loads(box[20:20 + box_jl])
    data = box_bin
    if stream is not None:
        s = stream(box_bin[:118])
        data = s + box_bin[118:]
        doc["bufferViews"][0]["byteLength"] = len(s)
        doc["buffers"][0]["byteLength"] = len(data)
    if edit:
        edit(doc)
    return glb(json.dumps(doc).encode(), data)


def accessor_counts(n):
    def edit(doc):
        doc["accessors"][1]["count"] = n
        doc["accessors"][2]["count"] = n
    return edit


case("glb/draco-vertex-count-lie.glb", "scene", ["Draco stream decodes 24 vertices", "accessors declare 1000"],
     draco_box(accessor_counts(1000)), "wb")
case("glb/draco-index-count-lie.glb", "scene", ["Draco stream decodes 12 triangles", "indices accessor declares 300"],
     draco_box(lambda d: d["accessors"][0].update(count=300)), "wb")
case("glb/draco-faces-over-indices.glb", "scene", ["Draco stream cannot be decoded", "12 faces", "ceiling of 2"],
     draco_box(lambda d: d["accessors"][0].update(count=6)), "wb")
case("glb/draco-truncated.glb", "scene", ["Draco stream cannot be decoded"],
     draco_box(stream=lambda s: s[:60]), "wb")
case("glb/draco-stream-face-count-lie.glb", "scene", ["Draco stream cannot be decoded"],
     draco_box(stream=lambda s: s[:13] + b"\x7f" + s[14:]), "wb")
case("glb/draco-stream-huge-face-count.glb", "scene", ["Draco stream cannot be decoded"],
     draco_box(stream=lambda s: s[:13] + b"\xff\xff\xff\xff\x0f" + s[14:]), "wb")
case("glb/draco-stream-vertex-count-lie.glb", "scene", ["Draco stream cannot be decoded"],
     draco_box(stream=lambda s: s[:12] + b"\x7f" + s[13:]), "wb")
case("glb/draco-bad-attribute-id.glb", "scene", ["attribute POSITION names Draco attribute id 7", "does not have"],
     draco_box(lambda d: d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"].update(POSITION=7)), "wb")
case("glb/draco-attribute-id-negative.glb", "scene", ["attribute NORMAL id -1 is not a Draco attribute id"],
     draco_box(lambda d: d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"].update(NORMAL=-1)), "wb")
case("glb/draco-missing-view.glb", "scene", ["KHR_draco_mesh_compression: bufferView 9 does not exist"],
     draco_box(lambda d: d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"].update(bufferView=9)), "wb")
case("glb/draco-unmapped-attribute-without-data.glb", "scene", ["accessors[2].bufferView", "Missing"],
     draco_box(lambda d: d["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"].pop("POSITION")), "wb")


# --- Kiosk files (vergence run --kiosk FILE) ----------------------------------
KIOSK = 'name = "k"\n{top}[[scenes]]\nname = "a"\nscene = "factory:10"\n{scene}'
def kiosk(top="", scene=""):
    return KIOSK.format(top=top, scene=scene)
case("kiosk/unknown-key.toml", "kiosk", ["unknown field `colour`"], kiosk(top="colour = 3\n"))
case("kiosk/no-scenes.toml", "kiosk", ["scenes"], 'name = "k"\n')
case("kiosk/empty-scenes.toml", "kiosk", ["needs 1 to 64 [[scenes]], found 0"], 'name = "k"\nscenes = []\n')
case("kiosk/bad-toggle.toml", "kiosk", ["toggles: unknown toggle 'warp'"], kiosk(top='toggles = ["msaa", "warp"]\n'))
case("kiosk/twice-toggle.toml", "kiosk", ["toggle 'msaa' is listed twice"], kiosk(top='toggles = ["msaa", "msaa"]\n'))
case("kiosk/bad-opt.toml", "kiosk", ["opt:", "warp"], kiosk(top='opt = "multiview,warp"\n'))
case("kiosk/short-spawn.toml", "kiosk", ["scenes[0].spawn: expected [x, y, z, yaw] (4 numbers), got 2"], kiosk(scene="spawn = [1.0, 2.0]\n"))
case("kiosk/nan-viewpoint.toml", "kiosk", ["scenes[0].viewpoints[0]", "finite"], kiosk(scene="viewpoints = [[0.0, nan, 0.0, 0.0]]\n"))
case("kiosk/idle-negative.toml", "kiosk", ["idle_return_s = -5"], kiosk(top="idle_return_s = -5\n"))
case("kiosk/twice-scene.toml", "kiosk", ["scenes[1]: the name 'a' is used twice"], kiosk() + '[[scenes]]\nname = "a"\nscene = "factory"\n')
case("kiosk/bad-mirror.toml", "kiosk", ["mirror = \"sideways\""], kiosk(top='mirror = "sideways"\n'))
case("kiosk/log-keep.toml", "kiosk", ["log.keep = 0: expected 1 to 100"], 'name = "k"\n[log]\nfile = "k.log"\nkeep = 0\n[[scenes]]\nname = "a"\nscene = "factory:10"\n')
case("kiosk/empty-name.toml", "kiosk", ["name is empty"], 'name = " "\n[[scenes]]\nname = "a"\nscene = "factory:10"\n')
case("kiosk/not-toml.toml", "kiosk", ["--kiosk", "not-toml.toml"], "name = \n[[[\n")
# A scene's viewpoint file that is missing, and one that is not a
# viewpoints file (another kiosk file): named with the scene's key.
case("kiosk/missing-viewpoint-file.toml", "kiosk", ["scenes[0].viewpoint_file", "no-such-viewpoints.toml"],
     'name = "viewpoint file that is missing"\n\n[[scenes]]\nname = "factory"\nscene = "factory:10"\n'
     'viewpoint_file = "no-such-viewpoints.toml"\n')
case("kiosk/viewpoint-file-not-viewpoints.toml", "kiosk", ["scenes[0].viewpoint_file", "short-spawn.toml"],
     'name = "viewpoint file that is not a viewpoints file"\n\n[[scenes]]\nname = "factory"\n'
     'scene = "factory:10"\nviewpoint_file = "short-spawn.toml"\n')
cli("kiosk-missing", ["run", "--xr", "headless", "--frames", "1", "--kiosk", "{dir}/kiosk/nothing-here.toml"], ["--kiosk", "nothing-here.toml"])
cli("kiosk-with-scene", ["run", "--kiosk", "{dir}/kiosk/unknown-key.toml", "--scene", "factory"], ["--kiosk", "--scene"], exit=2)

# The simulator's options: the distortion preview and the timewarp.
cli("preview-no-lens", ["render", "--scene", "factory:10", "--hmd", "valve-index", "--width", "32", "--height", "32", "--preview", "distorted", "--out", "{out}"], ["valve-index", "[views.lens]"])
cli("distortion-without-preview", ["render", "--distortion", "grid", "--out", "{out}"], ["--preview"], exit=2)
cli("timewarp-k-one", ["render", "--frames", "4", "--opt", "timewarp=1", "--out", "{out}"], ["timewarp=1", "2 <= K <= 16"])
cli("timewarp-too-few-frames", ["render", "--scene", "factory:10", "--hmd", "monado-sim", "--width", "32", "--height", "32", "--frames", "2", "--opt", "timewarp=2", "--out", "{out}"], ["--frames", "more than 2"])
cli("timewarp-head-turn-huge", ["render", "--head-turn", "1e9", "--out", "{out}"], ["--head-turn", "1e9"], exit=2)
cli("timewarp-in-run", ["run", "--xr", "headless", "--frames", "1", "--opt", "timewarp=2"], ["timewarp", "render --frames"])
cli("timewarp-with-occlusion", ["render", "--opt", "timewarp=2,gpu-cull,occlusion,superfrustum", "--out", "{out}"], ["timewarp", "occlusion"])
cli("rdm-auto-without-lens", ["render", "--scene", "factory:10", "--hmd", "valve-index", "--width", "32", "--height", "32", "--opt", "rdm=auto", "--out", "{out}"], ["rdm=auto", "valve-index", "[views.lens]"])
cli("foveation-auto-without-lens", ["render", "--scene", "factory:10", "--hmd", "valve-index", "--width", "32", "--height", "32", "--opt", "foveation=auto", "--out", "{out}"], ["foveation=auto", "valve-index", "[views.lens]"])
cli("aq-with-timewarp", ["render", "--opt", "aq,timewarp=2", "--out", "{out}"], ["aq", "timewarp"])
cli("inset-wide-1x-with-rdm", ["render", "--opt", "inset,inset-wide-1x,rdm", "--out", "{out}"], ["inset-wide-1x", "rdm"])
cli("inset-wide-1x-with-mffr", ["render", "--opt", "inset,inset-wide-1x,mffr", "--out", "{out}"], ["inset-wide-1x", "mffr"])
cli("inset-four-views-with-mffr", ["render", "--opt", "inset,inset-views=4,mffr", "--out", "{out}"], ["inset-views=4", "mffr"])
cli("inset-scale-big", ["render", "--opt", "inset=5", "--out", "{out}"], ["inset=5", "0.1 <= F <= 1"])
cli("inset-fov-zero", ["render", "--opt", "inset-fov=0", "--out", "{out}"], ["inset-fov=0", "1 <= DEG <= 80"])
cli("inset-views-three", ["render", "--opt", "inset-views=3", "--out", "{out}"], ["inset-views=3", "inset-views=2", "inset-views=4"])
cli("inset-wide-1x-four-views", ["render", "--opt", "inset-wide-1x,inset-views=4", "--out", "{out}"], ["inset-wide-1x", "inset-views=4"])
cli("inset-wide-1x-no-msaa", ["render", "--opt", "inset-wide-1x,no-msaa", "--out", "{out}"], ["inset-wide-1x", "no-msaa"])
cli("inset-taa-zero", ["render", "--opt", "inset-taa=0", "--out", "{out}"], ["inset-taa=0", "0.01 <= A <= 1"])
cli("inset-taa-word", ["render", "--opt", "inset-taa=strong", "--out", "{out}"], ["inset-taa=strong", "0.01 <= A <= 1"])
cli("inset-taa-four-views", ["render", "--opt", "inset-taa,inset-views=4", "--out", "{out}"], ["inset-taa", "inset-views=4"])
cli("inset-taau-catmull-rom", ["render", "--opt", "inset-taau,inset-catmull-rom", "--out", "{out}"], ["inset-taau", "inset-catmull-rom"])
cli("inset-sharpen-strength", ["render", "--opt", "inset-sharpen=5", "--out", "{out}"], ["inset-sharpen=", "S"])
cli("inset-sharpen-catmull-rom", ["render", "--opt", "inset-sharpen,inset-catmull-rom", "--out", "{out}"], ["inset-taau", "inset-catmull-rom"])
cli("inset-taau-lanczos-four-views", ["render", "--opt", "inset-taau-lanczos,inset-views=4", "--out", "{out}"], ["inset-taa", "inset-views=4"])
cli("inset-four-views-resolved-sky", ["render", "--opt", "inset,inset-views=4,resolved-sky", "--out", "{out}"], ["inset-views=4", "resolved-sky"])
cli("aq-scale-only-without-inset", ["render", "--opt", "aq,aq-scale-only", "--out", "{out}"], ["aq-scale-only", "inset"])
cli("aq-in-view", ["view", "--opt", "aq", "--frames", "1"], ["aq", "view"])
cli("budget-ms-negative", ["render", "--opt", "aq", "--budget-ms=-3", "--out", "{out}"], ["--budget-ms", "-3"])
cli("budget-ms-nan", ["render", "--opt", "aq", "--budget-ms", "NaN", "--out", "{out}"], ["--budget-ms", "NaN"])
cli("lens-unknown-profile", ["lens", "--hmd", "valve-index"], ["valve-index", "[views.lens]"])

# --- Submission costs (issue 17 item 5) --------------------------------------
cli("cad-without-count", ["inspect", "cad"], ["'cad'", "cad:N", "1..=100000"])
cli("cad-zero", ["inspect", "cad:0"], ["'cad:0'", "cad:N"])
cli("cad-too-many", ["inspect", "cad:100001"], ["'cad:100001'", "1..=100000"])
cli("cad-not-a-count", ["inspect", "cad:lots"], ["'cad:lots'", "cad:N"])
cli("record-threads-zero", ["render", "--record-threads", "0", "--out", "{out}"], ["--record-threads", "1..=64"], exit=2)
cli("record-threads-huge", ["render", "--record-threads", "100000", "--out", "{out}"], ["--record-threads", "1..=64"], exit=2)
cli("per-draw-unknown", ["render", "--per-draw", "uniform", "--out", "{out}"], ["--per-draw", "uniform"], exit=2)
cli("record-threads-with-gpu-cull", ["render", "--record-threads", "2", "--opt", "superfrustum,gpu-cull", "--out", "{out}"], ["--record-threads/--per-draw", "gpu-cull or mffr"])
case("plans/record-threads-zero.toml", "plan", ["config 'a'", "--record-threads", "0 (supported: 1 to 64)"],
     PLAN.format(frames=2, opt="two-pass") + "record_threads = 0\n")
case("plans/per-draw-unknown.toml", "plan", ["per_draw", "uniform"],
     PLAN.format(frames=2, opt="two-pass") + 'per_draw = "uniform"\n')
case("plans/per-draw-with-mffr.toml", "plan", ["gpu-cull or mffr"],
     PLAN.format(frames=2, opt="mffr") + 'per_draw = "ssbo"\n')
case("plans/timewarp-reference.toml", "plan", ["`reference` does not run it"],
     PLAN.format(frames=2, opt="two-pass").replace('[[configs]]', 'reference = "two-pass,timewarp=2"\n[[configs]]'))
case("plans/bad-cad.toml", "plan", ["cad:0", "cad:N"],
     PLAN.format(frames=2, opt="two-pass").replace('scenes = ["factory:10"]', 'scenes = ["factory:10", "cad:0"]'))

# --- Point clouds (LAS 1.2 / LAZ) ----------------------------------------------
def las(n_points=3, claim=None, fmt=0, scale=(0.001, 0.001, 0.001), offset=(0.0, 0.0, 0.0),
        bounds=(10.0, -10.0, 10.0, -10.0, 10.0, -10.0), points=None, cut=None):
    """A LAS 1.2 file of point format 0 (20-byte records): `claim` is the
    header's point count, `points` the (x, y, z) integers written."""
    pts = points if points is not None else [(i * 100, i * 50, i * 10) for i in range(n_points)]
    h = bytearray(227)
    h[0:4] = b"LASF"
    h[24], h[25] = 1, 2
    h[26:26 + 8] = b"vergence"
    struct.pack_into("<HIIBHI", h, 94, 227, 227, 0, fmt, 20, len(pts) if claim is None else claim)
    struct.pack_into("<3d", h, 131, *scale)
    struct.pack_into("<3d", h, 155, *offset)
    struct.pack_into("<6d", h, 179, *bounds)
    body = b"".join(struct.pack("<3iHBBbBH", x, y, z, 100, 0x09, 1, 0, 0, 0) for x, y, z in pts)
    data = bytes(h) + body
    return data[:cut] if cut is not None else data


def bin_case(name, kind, expect, data):
    path = os.path.join(OUT, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)
    cases.append((name, kind, expect, None))


bin_case("points/header-cut.las", "scene", ["header-cut.las", "ends early"], las(cut=100))
bin_case("points/count-lies.las", "scene", ["the header says 5000 points of 20 bytes"], las(claim=5000))
bin_case("points/records-cut.las", "scene", ["records-cut.las", "ends early"], las(n_points=20, cut=227 + 20 * 12 + 7))
bin_case("points/unknown-format.las", "scene", ["unknown-format.las", "format number: 42"], las(fmt=42))
bin_case("points/nan-scale.las", "scene", ["the x scale NaN"], las(scale=(float("nan"), 0.001, 0.001)))
bin_case("points/zero-scale.las", "scene", ["the y scale 0"], las(scale=(0.001, 0.0, 0.001)))
bin_case("points/nan-offset.las", "scene", ["offset NaN"], las(offset=(0.0, 0.0, float("nan"))))
bin_case("points/huge-extent.las", "scene", ["span more than 1000000000 m"],
         las(bounds=(1e12, -10.0, 10.0, -10.0, 10.0, -10.0)))
bin_case("points/nan-bounds.las", "scene", ["are not finite"],
         las(bounds=(float("nan"), -10.0, 10.0, -10.0, 10.0, -10.0)))
bin_case("points/outside-bounds.las", "scene", ["point 1", "outside the header's bounds"],
         las(points=[(0, 0, 0), (2_000_000_000, 0, 0)]))
bin_case("points/not-las.las", "scene", ["not-las.las", "LASF"], b"ply\nformat ascii 1.0\nend_header\n")
# A LAZ file vergence wrote (220 points), its chunk table offset (the 8
# bytes where the point data starts) pointing far outside the file.
TINY_LAZ = base64.b64decode("TEFTRgAAEAAAAAAAAAAAAAAAAAAAAAAAAQQAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAHZlcmdlbmNlIHNjYW4AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAHcB2wEAAAEAAACHJADcAAAA3AAAAAAAAAAAAAAAAAAAAAAAAAD8qfHSTWJAP/yp8dJNYkA//Knx0k1iQD8AAABmZmYTQAAAAGZmZhNAZmbGzMzME0D+1HgcWsQiQKAcWiQIrMQ/16NwcD2qI0AAAACAmZm5PzMzY2Zm5iFAALweBVK4fr8AAAAAAAAAAAAAAAAAAAAAAAAAANwAAAAAAAAA3AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAABsYXN6aXAgZW5jb2RlZAAAvFYuAGh0dHBzOi8vbGFzemlwLm9yZwAAAAAAAAAAAAAAAAAAAwAAAAICAAAAAAAAUMMAAP////////////////////8CAAoAHgADAAsABgADAK0JAAAAAAAAIAQAAAAAAABAHwAAAAURAAEAAAAAAAAAAAAAAAAAAP8A/wD53AAAALMDAAAWAQAAAAAAAAAAAABeAQAAAAAAAAAAAAAAAAAAAAAAAFMBAAAAoYTJ98ue2ZE4qC3QMwcrUUK3RTyymZb72Rd0LK6v0cWpcjUwffDi2yLCnQ0yk29zVHfpBvThHWM5ffC6WXy1jjUP7cIrvUXqE2iofOadAc6dYqxJ1PvaQhmYKph9sA8YeBs3ExzyOAh3hdoKKiZRZJVG2miR1a/Bw0hlbLcHjhXkPCiMIVEoUDDuEZr/xOZ5lYun4cZQJskr/h6aCmvWAZKsjZWrlb9wUuUHjnGIP/2nYdB+fEFaqBThlnvFEzNz9FaIbksMxIdQhIV7FMkJtkqNfytryCzWGWf7WnPZre5+dXVa1bfcryO5QrfSdYVWa+8Rjt4CBo21lok93zo2UyYrGgCzmdYx5AJo5ON+kknEyF1HqXr7aMAnf4lsOsqO0XrAUsdYqpE1G8NYNq0v4I1zEnr5N7QA7ytDsd/j4wZhdWS6esdt6GNU02m6kRfQJt6OpLqKHFxW2SDpCZEpB3CXnQcIr3Xha5/8z31yv3uJxS/5jp5BL0MY2bGk2tPZRs58Jq6zO7e6TTIDKdxK1u6TZ0G5+LuRVGqKuwiUlG/M+f5GmGXF6M1pLHJ0YXgfQH40RwERRpiQtnoDGmPhyZEU0S395blDPf4CaW6c1lQgX03zr79/30fD90eKpdc7hiKOkKfLCOBvxqZzNI6an2fOFA1/gUx5wyXpjTuz1rXasTSWX8Fz3c9AuWboKPJQH/UEOzyOPN3dnOyJepnufNi+iVJzkZgrMgUe9+J6AtxeUHU8ZvWD7R5GeW0tCgJGg53wrFQgGY61cHdnszqpSfEXpkbCbIIiXFzAoMRhE2eQgeuAv8rey24SxbZ07NEjyUFInJ8buGG3l66P/xjjoBhIVQEM/1yT58KTlSWNzY6wTfAaSPHLcSQCd0ZwMCRWOijzs9vO3+nekrpv+tfUDN2DZw05OyF+5+DUInYyxdw/h0qXgvkIqLSjj+zseBaAuJtp4ybhrnpDtSymiylIvygNiF+ij65nTbwMioMZOn2zBdZr27aXpJh3aT4svw9J2qvcLG9DEXUb6/90dvyA956LPlYUai8JYG0a0QDwAAanT+sXVgMXsB6EnqXrGkw7ab+vjJaTRvd7jfrK47hF+E/PPyUWHTIJodOI4FpzFJArzLSGBH61EDKbyHS4NmwGhoaXATUtsdg5XK6kVGvIJ4dtVcr7YzI+yn6UD9ezsP/hetyfDYTjTDBgFp28AUbI5oRxuZOUY2wwBRT9dToaZF3uzMDKdUtGXUFXMA6/NwAAAG9J5olI9//9lS+0BtBJA5P/ClfBvpHDjqt3iRp8R3NvFbNyNQgoE5rLhPE/LlK6ZmYRWQO9aGSfR6UoKau3sjFMriNacnXaWEGYRXqg8s+dudCj6k08Q/RsOb/t6PhhT1eAd2Xd6dGLhDY65L4kw1VpV2l31lkY5GhuKn87IX+kZOliSW4H82gN4lFLyAohpy2iIzLCVJw+K5cW1Cme9z+vYCLYC+2GXbS0d0NF46lsf4FGly30lYL0+rWuo56OZpfhXQ+drymvXz+FKk/5TAizuhpIzclxuGQ5QwM9HQRpdlTANnEifArXLK1s2CsRjqIzViEmY9u0AMw51etZ7wPk7hCVS5a78vETdwp1DYSTwUuLAAAAy8G2rolcwktDv7XTiBfUCYeIqt4lUp2DzICdbord/yZDyJj/w/CHWaD+ArZk7VMdJ6VSLB8fqiIOnk1uzzlHyDVjde0FK8MT5zychM0xA2kLb3zVIojyROU5bJ7yyEaBsVrwVbv16o7EcoFb8HmueG9tKrgjm71Op3a1p3Cs/oeSVxaN449H0Zxf1eRIngIfuJTEdTKoAWifWOvbVMs4M2QY+aSK4KXkJbT3mj+vVO0VGfNigK6SeiDC5kQzY4fIj4Rd7tc9P0lEIV0SPpm/YwfRFjxcgEP58YfNuUODMAlOqtlCYgqSgj9uY3B2bdNFN1TIy8y95CtRppty5Dw+TIegnZkD4rOg1I5DOTTx7gSBOZupgJ3F42lpPicQyMEK73vGVJeN1VNocSIRRGWvTA6Kb71oyoF6OX8kOemYeE2bjfrvP/ZzNm0TBTJo6sh3UXAKEkZVLHL+KgQAAADV6HagREOHDhw4cOHGIx46ckM+gwYxGPHTkhn0GIRjx05IZ9Bgw4xGPHTkhn0GIRjx05IZ9BiEY8dOSGfQYhW0KDP5U7upaIx46ckM+gwYxGPHTZ/DjFM+gxCMeOnI9YcLUIQqd3UtFbQoMV8OMQe4jPc3wi8j1hwt6ILLLbRYcLUITBZZbaLDhahCYLLLGcpn0GDDjEY8dOSGfQYhGPHTZ/Dhxe0H+uHGwYGQVS3B0CL1oU6iXPW8knHlShLoX2BsjStpZ/GUcFwqn1wMI6XM71cHLhq1bEVrt+pkNmABamJoqTdUAytsGw8jkNIVtXDiaZ4KBXja3Pt0zNk6Yq+ICcveRXnPOMtFTDoTVGR0s4sm8uGtvYQ6Y7ZqxgOjwrPOJ3UT/Q9Y8cKVF7cta26LEH8cNmj/9isIDVsRbOg8gDBr3par+bGiHir7470EjBIAAAAAAAAAAQAAAFzgBAAAAA==")
lying_table = bytearray(TINY_LAZ)
start = struct.unpack_from("<I", lying_table, 96)[0]
struct.pack_into("<q", lying_table, start, 1 << 40)
bin_case("points/chunk-table-outside.laz", "scene", ["chunk-table-outside.laz", "points outside the file"], bytes(lying_table))
# The same LAZ header claiming a billion points in 2.5 KB.
many = bytearray(TINY_LAZ)
struct.pack_into("<I", many, 107, 1_000_000_000)
struct.pack_into("<Q", many, 247, 1_000_000_000)
bin_case("points/laz-count-lies.laz", "scene", ["more than a LAZ file of"], bytes(many))
# A mutation of that file (found by tests/fuzz_mutate.rs) on which the LAZ
# decoder asserts instead of returning an error.
bin_case("points/corrupt-stream.laz", "scene", ["corrupt-stream.laz", "decoder failed"],
         base64.b64decode("TEFTRgAAZQAAAAAAAAAAAAAAAAAAAAAAAQQAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAHZlcmdlbmNlIHNjYW4AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAHcB2wEAAAEAAACHJACVAAAAlQAAAAAAAAAAAAAAAAAAAAAAAAD8qfHSTWJQP/yp8dJNYlA//Knx0k1iUD8AAABmZmYTQAAAAGZmZhNAZmbGzMzME0CF61HrUbgjQIDrUbhRuK4/aJHtr3JoI0CAj8J1j8K1v+Oly/dT4yJAABjZDiuHhr8AAAAAAAAAAAAAAAAAAAAAAAAAAJUAAAAAAAAAlQAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAABsYXN6aXAgZW5jb2RlZAAAvFYuAGh0dHBzOi8vbGFzemlwLm9yZwAAAAAAAAAAAAAAAAAAAwAAAAICAAAAAAAAUMMAAP////////////////////8CAAoAHgADAAsABgADACoHAAAAAAAAYgIAAAAAAACgDwAAAAURAAEAAAAAAAAAAAAAAAAAAP8A/wD5lQAAAHcCAACqAAAAAAAAAAAAAADuAAAAAAAAAAAAAAAAAAAAAAAAAOgAAAAAoCvJEtZuYHnzgboJ/F2Ke3ZW0d+1E05G36ExCqmNo5nYu990dDijDxd3nTB4MTCelX3LEuue7f0UUnQB+LPuiwOfz+PmpfCfDW6v5flEG6DK6DpjJtaGnCFbjjQg9jriPpGTjCO7Wp2qMdFz0OV0ucqybq949ZZhSxqNq4fGRPcc0QWC1nejVKT7hNASThaZTYMQE/rwaQl0LSIuWjbh3XXXZhtc9ZGlJO62hTSGuuFJThIjwkPNeJZ59g1AW9eebgZrmtmPXTS+d4uhlSfgoAQufOIT4EsPR7ygPw/H6qJ9dZdvAHutVJPkGfo8fzybXK2USVQZ+eLez/9Hd792umEkVCPQXF6QToI6ZNlLrFyGElhLg9lWXftDjqW4iZkgiuhmLBiiEWvQLf7rVfdt8tuhllBt0pwX8iM+DQXU5YOt2YG5nEsfkyw7YViIGh60PZD9PkVdHbpVTqCDNG1iOJw0nZTl3TtN0o5dAZ4fAHuLDb6F9il/x50+f+fCpCe7WuYggiaOGoUwLTRXFA0v1SCXPgclI8eAc68RsPcnlSj/LLNX2Obb9KKw2CkmRyEEi67BlSxM5HiTXnENR/4ohpb+Wrk2EKSObIhaNuHddddmG5KCFlw4zn/gqKrh7wl6H/oOBj6DIDibLJgGSB/h/X+KyALLeO+37i8X6dSTI6FjgZymBon1a5Zxx4Ffe1UgP/VgQOupuSoadvvS73BLPOq8MdUuTgqYYEvHhMkHjcXA2W3DXMmw6KlRxw52jAOYQD7ciA5ZkgMEeWs++tqMCNEfEX1hKwyWrOZfs93U5fO1uwzMW+ky0CiWt6ZkKCXXE1UMpVLCnEP3/ZQK14TjQCX9TDQAAABoHzVkQJPT9QDFCsxH3iqaCpOrd2mGBNipgkCpfii261c0WkM9zIE3AjOD9rFbZeot32gL3jyUDQMmDM4LC7fErO1np1JYqsiS0XTjpyAxQieC1+3ENjvVPmA4k4ejp+/+c8kT6OavydR9FJ3wBMvxMiE2XhJV1MbCMS5qTNeLIekj+naKgpN9Q0gi1sIrKQNzQ5UMyamL0mITqO+8AIL1Nm4sBhVhkb8AAAC0sxMdBoYw0R/JcHP6sldQ3NmOS/4ZwgDkV55x/eUpBpry8umCAlBd3QhNyum+4+TBk9BmiCxburE6J3ofOZBq3vpvlLPx1QGUmGD00j8dPeocU2HSDHgSIu1+fAshqIinJPcNui4tKN5UXFQIsO7fuvfxYsSKSxLJKokfRDywT9N7GZ41pFOlrqI919ievhfS3aQChtkzYA2kVwv41LLbWyJTKr96yZ42xwcOszVTUAf+VXSs2ts7Wx3TWNGsNP/HkWWLKV13F4llU7iP59YEhVbkU/sCiPm3z+Gxljb4MhO0JxY+/F82yL0vAAAA1Ytw4xGPLTAdOSGfQYMOHGIx46ckM+gxCMeOnJDPoMQjHjpyPWHC3ogssttFhwt51Tu66m0KDP+Cyyyzhxiaw4W86p3dS0Rjx05IZ9BhFzuyO3wi7Qiaw4W9Ry/2ehDjE7yW981C35FiHDjEWDec7f6TynyHDhw4cOHDhxiLBvOdv9J5eUwbznb/SeU/kWDec9QLo/KHUR50ETRa0cYozP2RRaEgY6kTFt/Bbr9E0mYzox90PgqjS4cWmH2DuaFrzdR36HOmByZvqC4LLJgGSB/hZi77xpRjAAAAAAAAAAEAAABacKMAAAA="))
def ply_ascii(count, rows, props=("x", "y", "z"), fmt="ascii 1.0"):
    head = "ply\nformat %s\nelement vertex %d\n" % (fmt, count)
    head += "".join("property float %s\n" % p for p in props) + "end_header\n"
    return head + "".join(" ".join(str(v) for v in r) + "\n" for r in rows)


case("points/count-lies.ply", "scene", ["count-lies.ply", "vertex data"],
     ply_ascii(40, [(0, 0, 0), (1, 1, 1)]))
case("points/no-x.ply", "scene", ["no 'x' property"], ply_ascii(1, [(0, 0)], props=("y", "z")))
case("points/nan-text.ply", "scene", ["nan-text.ply", "vertex data"], ply_ascii(2, [(0, 0, 0), ("nan", 0, 0)]))
bin_case("points/nan.ply", "scene", ["point 1", "not finite"],
         b"ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         + struct.pack("<6f", 0, 0, 0, float("nan"), 0, 0))
case("points/huge-count.ply", "scene", ["99999999999 'vertex' elements", "more than the file"],
     ply_ascii(99999999999, [(0, 0, 0)]))
case("points/bad-format.ply", "scene", ["header is malformed"],
     ply_ascii(1, [(0, 0, 0)], fmt="binary_middle_endian 1.0"))
case("points/huge-extent.ply", "scene", ["span", "more than 1000000000 m"],
     ply_ascii(2, [(0, 0, 0), (1e12, 0, 0)]))
case("points/no-vertex.ply", "scene", ["no vertex element"],
     "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n3 0 1 2\n")
bin_case("points/truncated-binary.ply", "scene", ["truncated-binary.ply", "vertex data"],
         b"ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         + struct.pack("<9f", *range(9)))
# An E57 file of two scans (300 points) written by the e57 crate, cut and
# damaged.
GOOD_E57 = zlib.decompress(base64.b64decode("eNrt2HlcU9e2B/BDEsaQhCq9zoq0OFUIo4AKLkVRBEQRQWUQhDAJBEIQwQHB4oBVnKvWGVFCIMwQJkUcUetQrEPr0KrVWkU7KHrt4DsJPyvea1/bz+v7vPs+n27+WCFn7X3Od+2wP1mMnurnbTnOwVGHwbDuCNPNOuIXfLzP6wgv83gmHXEy8/rQYW6J9JhSnuZnE6P50Q7KIFPV+C/T2Tg4KLf5CRtdjC7lJY7OIF913+z7bIzUjDEZNF+TyEY2a1CQWwbtTWQz2ahJmzI2gz4+zQ42fpnOJo7LoPZB7IJs1Czn4p5B/dg0NRvtNGN8Bk3QJmaQ5raDJmRQkubGbNSk9fXIoK1b2MFGzeOZTsygw+xtc9moWc7IM4MesGnZbNQ6vODwgsMLDm84vOGYBMckOHzg8IFjMhyT4ZgCxxQ4fOHwhWMqHFPh8IPDD45pcEyDwx8OfzgC4AiAYzoc0+GYDscMOGbAMROOmXAEwhEIRxAcQXAEwxEMRwgcIXDMgmMWHKFwhMIRBkcYHLPhmA1HOBzhcETAEQFHBBwSOCRwRMIRCUcUHFFwRMMRDUcMHDFwxMIRC8ccOObAEQdHHBzxcMTDkQBHAhxSOKRwJMKRCEciHElwJMEhg0MGRzIcyXDI4ZDDkQJHChxz4ZircajH7LdnLamwpMIyD5Z5sKTBkgZLOizpsMyHZT4sC2BZAMsCWBbCshCWRbAsgiUDlgxYFsOyGJZMWDJhyYIlC3uyBI4lcLwPx/twZMORDcdSOJbCsQyOZXA0ZXU878Gsjudio/b+bNTeh43a9dioncdGrZONWg8btc/NRu3zsVH7HGzU3o+N2vocyOqoAxu1XjZqXWzUPj8btc/JRm1d2aitHxu1dWKjth5s1LrZqPWxUes4AEcjHI1wNMLRCEcjHI1wNMLRCEcjHI1wNMLRCEcDHA1wNMDRAEcDHA1wNMDRAEcDHA1wNMDRAEcDHPVw1MNRD0c9HPVw1MNRD0c9HPVw1MNRD0c9HHVw1MFRB0cdHHVw1MFRB0cdHHVw1MFRB0cdHHVw1MJRC0ctHLVw1MJRC0ctHLVw1MJRC0ctHLVwqOFQw6GGQw2H+vanbQ9hUcOihkUNixoWNSxqWNSwqGGpgaUGlhpYamCpgaUGlhpYamCpgaUGlhpYamCphqUalmpYqmGphqMajmo4quGohqMajmo4quGohqMKjio4quCogqMKjio4quCogqMKjio4quCogqMSjko4KuGohKMSjko4KuGohKMSjko4KuGohIMxoR2Xgy0sL4nowNftztNCRHT0H11yPbYKqUfktqefrRNQ3ug2bo6vMQ2XLvuk1x0jSnQ4VN8tyJAujE4xsjuiT91LBMpSKz06uPZth3olj/Ze6NN2cCKXdpz63Pd8Dw7dbp6V1c1Ch9reGWLuN5ehD5aGnFtkylCXVVP0F3EZWjx5kM8LN4a+kZ/yTWxl6NjbLX17FOnQuWEei/yPcqj3/gTz77vySLk/2WRjji5tsMs/5tNTn3iy5kLbCgMKjBGovh1rRCFtA5TZB/n0TlzL51e6Cmh3s9nNQHsh5VxVjF75togaDUKa41Uiksf2Nbn/TESD1o9/ZPS9iIyS1qzsulVEro43lUsfC0lvQvXdn/WFNHyQm+fda8ZkktTWwyKLT59lOWRv4BhR7FvtlosTDEj/Y0NT3kU9GhjU1zLGQ5cSTZXWGZe5dOipl/OPazm0vU5e+GWWDuWn+fvrVDP0+cXn4mw7hkYE2T3axX7DnXrE/p+B/RgKO1KiXLCaIaevGq5t8NChqu4v/iH24ND5EUtLei7hkvLL7LOt3/Doqz5pg7kyPer+1CzAxNCAYlw3cw/tNKSx997KuW7Bp9FdHyd8vtKY/B5l9pQdFlDalZ6Zw5qEtOrpwm9M54ko8KLVSfUtETUcmJF76RcR3R9Rlhh0QkRWSzxSkseIaNmiVo9kmZDeLU4+si9UQL1Wubs962ZM9usmjcvKNyLRyanx+W3NKsPuhiTYv00QlaFP+/UPfXH7vi6NOevhtyWeR9vXn+/a3JVLhy9OPzDogQ4N9hwn3sTRoW/qtzrNDGXIN/j+lgd8hh6cuP9zoQFD78hn7qr2Z0gR+cnz779naOdp4VKLS2wNLi73dHjOofFnCg4sm8yjW6bfDk49rUsBB1OeXgvRpy2ttuPLnhrQvZmxir1LjSh0udXccz/yqbdHgJnfBAHd/nYU/2GIkG5dUX2aZS+iG+/1rVrdJCJm2cKgBT+LaJPZ+0+vfS2iPtF6T7KXiCixi3feovNCmjTL+PEXVwQ0bvV54w/2GZPBxqHLmtz4FDe5NSLvoCF9mvS4oniwAR3LMcgXrtMj5cRTwXqGujTE1rwf7eDS8qBtM21DORTUZ0+3lYE6tG/G0RzVVtbV5ZG+twVDJy+cXGHK7n2t36RHi4cytDDz1MXTBQxt3te7jJuoQ3k9ZH726RyKWPKRUXMDlwa9t+rGuSG6xP20+fqJKj3aNNyUd9/bgFS77j767qYhdfXa3V4TwaeHny958Plh9rN6vFfvkO8F5NPoZiG+LSSDJbu6KHNFRKMljT+2sc6BTutDfhSRKqVv+8QaEQVfaVGlvisi259KnQ9OENL82L2Gt4cKaEKP9f0dr/LJNP6rje9GGFHr1MFrClsNKEvdz7NpuD5ZHLlgVqHQJYvQw4MXW/PI9rlQZHOdQ+06jmvHNOnQd2M++rLnTYaa2hWeG70YGhBtcn6/LkO9dJOmDjBh/+bL31fnz2Go1U8sXmyqQwlFP8Q853KoR26r73JrLj20TJxvtZpHjZefRf4k1COf/Isfb83TJ0aHw+Xp6ukbGBrxjQVCkclbXbqavv2Pbt179OzVu0/ffmb9zd9512LAwEGDh7w31NJKbG1ja2fvMMzRyXn4iJEurqNo9Bi3sePcx0/wmOjp5T3JZ/IU36l+0/wDps+YGRgUHDIrNGx2eIQkMio6JnZOXHyCNDFJlixPmZs6Ly19/oKFizIWZ2YteT976bLlK3JWfrBqde6atevWb9j44j9yMH/5GGCwZsdfsc6//k8gwuQP/U9gOfqE5egTlqNPWIE+YQX6hBz0CTnoE1aiT1iJPuED9AkfoE9YhT5hFfqE1egTVqNPyEWfkIs+YQ36hDXoE9aiT1iLPmEd+oR16BPWo09Yjz5hAxwb4NgAx0Y4NsKxCY5NcHwIx4dwbIZjMxxb4NgCx1Y4tsLxERwfwbENjm1wbIdjOxw74NgBx044dsKxC45dcOyCYzccu+HYA8ceOPLgyINjLxx74ciHIx+OfXDsg2M/HPvhKICjAA4FHAo4CuEohEMJhxKOIjiK4CiCoxiOYjhUcKjgKIGjBI5SOErhKIOjDI5yOMrhqICjAo5KOCrhqIKjCo5qOKrhqIGjBg41HGo41HDUwlELRx0cdXDUw1EPRwMcDXA0wtHYax1vBiwHYDkAy0FYDsLSBEsTLIdgOQRLMyzNsByG5TAsR2A5AssRWI7CchSWY7Acg+U4LMdhOQHLCVhaYGmB4yQcJ+E4BccpOE7DcRqOj+H4GI4zcJyB4ywcZ+GoRJ9QgT6hAn1CBfqECvQJFegTKtAnVKBPqECfUIE+oQJ9QgX6hAr0CeXoE8rRJ5SjTyhHn1COPqEcfUI5+oRy9Anl6BPK0SeUo08oR59QDkcZHGVwlMFRBkcZHGVwlMFRBkcZHGVwlMFRBkcpHKVwlMJRCkcpHKVwlMJRCkcpHKVwlMJRCkcpHCVwlMBRAkcJHCVwlMBRAkcJHCVwlMBRAkcJHCo4VHCo4FDBoYJDBYcKDhUcKjhUcKjgUMGhgqMYjmI4iuEohqMYjmI4iuEohqMYjmI4iuEohqMIjiKNI/zbgh6spQiWIliKYCmCpQiWIliKYCmCpQiWIliKYFHCooRFCYsSFiUsSliUsChhUcKihEUJixKWQlgKsSeFcBTCUQhHIRyFcBTCUQhHIRyFcBTCUQiHAg4FHAo4FHAo4FDAoYBDAYcCDgUcCjgUcBTAUQBHARwFcBTAUQBHARwFcBTAUQBHARxszNe1EH89wpAm+PFl248bUc2Ww3qPhxnTIsOzd93nC+ieoYVJwTIhLZ/4LDFiiogum3u9m3SO7aPsbmc2vhBRZY+L5yKviaj+w0FLT8WKyDm9m9fCIiHd7LshtEuhgI7uuT/gcrwx+d9p5cTy+BQS97TYeoEh7TYcOPjsbX16HC4YsGSSHvH29nPPaOFRaVzqyXESLp0/f8jTyJpDnBxli9kwHToXa3AlI5OhTUbnH8/swdBldcOLyzoM9by74va9EQxd/GyOrstRhk6vGXF1+mYdas/y+uyTIg49Kcr3zn/KpYN1z6/vnKNLktM+Qx/+U4+cn2Sbl6wzoMaTAwQfWhhR7+GyOxv38KlmiI/7/OfGFG5gELW2n5CixqnfGqwnotTSkOsm+Ww8k633wxMRNd59YryJjVZ56/f9nCeidypXbojliehCqXeScx8hnZ8y5PDup8YUkOp8P2Ann6auWVv6trkRjRz6zyHCXAN6aNK0x7ddj/rnfr/BKlqXZo/IlGQ+5tK2p/mhvQs59MG+1sXvbWL76BubmZLDDO1+K8mUr3FSqHs56z5xIepaG1uH3Vkjlx/LYsjTKdRZ6KRDLWNfnM2x5VBRsPizUdFc8nzSknHhNI8GPVJnv+WrR/w+e8JlX+vTh3ed8g5nGNLSDV84ndBn+93LvV1vJBqTq020LK9IQFaq3AGLVPqWsmwhfdHWv2ZgnIheJFXONbkuoin9Xa8Us3u/ee13pwvOiuhO8vqo+z5sj3mqOmgVm1+c5c7bNU9AJg1nuFftjEkhuXbT7ogR7bUZdtfHyZAOLUxZ+GynPqW5X3k3ha9HZ/0tJt7J4dHV655luyy51P7p9p/X6HBI7hKzsbiLDl0dFbFyQSxDvNJv5pSLGOozRHCmje0tH2y7PnudN0NMMuenI7fYvffhly9v1iG9t4fo/PQFh/Y9mBdXYccji7WXjKyKdWmR/HLALFd92tFgf3LCJQMaHOVusj3KiCaJchMjb/Cp+oBbkUIsoEHd07/6ZaKQ9FwXJvYcICLXF9/2IrWIFnMdAraxvfSl4qGKDLa3nj9jRff01SLK9LoRP+2mkLqP7Jfz8JGAPt5vGPSoyZjsFUmj4sL4dGHXV5XRNwyJ88kPgRMmGpBibs0tm3I9mvt8p33sQF2yrjkkUdVy6Ztiz97rUzmUcjW94VE86753dGbgfoZMnp/f1/QeQwaLxvYTMAwJ24THf7FgaHZmenCXbQy1n407sy5Yh07U+7m0zOaQOzehyXM3l3qsvlAQZaxLgtGVPfM26tGtbo9PTrY0oNw7y34RHzYk5xULY7uM59Osd64FZCqMyX3V45TAq+zeFwaYSFqFdOH48a+PvC+i9ryWuuh7Itp6smuU988ieqB0v7P/IPvZr+SFtdmKaGrLmZ51QUKKbt4j3jxOQIm/NMYVPOPTroJfGq2XGNGQEqbG9LEBrei2eIdLoD6tab9s9OyELp3o+2y5tzePLt1JfRT6lEMbzgbfbr3A7p9KeGDEdwy5hE/zVE5j6N5GrrO/AUMDNo47NsWY+ft/An9iRPyPxsAt/nsj/pfGyFHz4uPM5kpkyTHSBBdzGytrczNJQrg0IiYhysV8mp+7pZP5KFejkRIHR1+pVG4mT0uUuJhPlctSwuUpMom5GTs9IdnFPFouTxwuFqemplqFJcvjraSyKLGbj7e3h594nIOj2NbaxtqSXcNyruYO7HqRUll8mHxSWLzk1ZLsLc1dR/YPdBs72m904Oipft5m7Fwzu7FmHvFhUexVs7Fh8jAz95g4SXCw60jxqzXYBaNSYiJ+aymWF8WiJJZySbLcMvLlfM0Udibw3mGxUhlW8EiQS6IkMnNXm5Hizpc7Zcck/Hu29atszeWOsnnFzJaFydL8Oy781iP6piTLtVqkm821trKxsbKxM4uKkUenzLYKl8aLw2VpljEJ4WJ2VS3g31Zn7xjBloitWMdt/CXhcqnM3CwsLk6aOkEil8ikbCEk0pRkt+iYuAiZRLPl5lqVJlH75r9t8e8UNzk8LMHSunNBw8NkbKFjwhLGSFMSIpLftOA8tkAx8SnxuOYeJw2Tm7s6WLMVfHlJmxU2701Z9lb2jprEjqtsYtqbl3N2snJgdzDt1Yppb1xxmOa+aa+WS3/jcrZW1uywc7ZxtBtm7WA3zG6kOP3VyulvXNlek/PruuJ/qYymVtI4qcwrJj5G/sY6aS/b/yC18ZVEvP5QnT902qxXGS/nad557aF+nWPr4NBp1q/Pp31nvEwiSfide3XOeX3e792vc9bLmWPiUiS/c8NOKa/N+r3bdUrS1v9VtdlfE6UxCb+W3U0anyiTJCdLIl7+0WjOCZ/IyGSJ3MXc3sncTCYJl8oi3NidY9+wcdAeY4kyqVyqWeCNm/dyt6e//qGw7vRBmN45b8Zv583onDfzt/Nmdtr8fymLWXxHAV3M2TM+vqMoLuZsrV77DL22nX9+Be20zlv055fQzNJs1q+11f6i3SvNq05H1V9wcNn8RQeXvZXDHzq6nKyc/9jR5Whl/fLoOsPnt/x3x5f2nPvDB5itg7Wtk72z3TAbu2F/4ASzs3J2dnZytLNxdLC3dnR2svsrTrS/T7P/29PMZpj93+fZf+R5Ju74/sa+imG/80qSbdmvcgH9LW7/ua9z4peTNa/x1d3ViPl7/D3+Hv/vRrj77OP/BdLGkIE="))
bin_case("points/e57-cut.e57", "scene", ["e57-cut.e57", "not a readable E57 file"], GOOD_E57[:5000])
crc = bytearray(GOOD_E57)
crc[3000] ^= 0xFF
bin_case("points/e57-bad-crc.e57", "scene", ["e57-bad-crc.e57", "invalid checksum"], bytes(crc))
# A scan whose second point is NaN, written by vergence's own E57 writer
# (tests/points.rs makes such files); kept as committed.
case("points/e57-nan.e57", "scene", ["e57-nan.e57", "point 1 at", "not finite"], None)
bin_case("points/e57-garbage.e57", "scene", ["e57-garbage.e57", "not a readable E57 file"], b"ASTM-E57" + b"\x00" * 40)
case("manifests/points-grid.toml", "scene", ["points[0]", "not a grid or motion"],
     'name = "x"\n[[points]]\nfile = "../points/count-lies.las"\ngrid = { count = [2, 1, 1], spacing = [1.0, 0.0, 0.0] }\n')
case("manifests/points-missing.toml", "scene", ["no-such-scan.laz"],
     'name = "x"\n[[points]]\nfile = "no-such-scan.laz"\n')
cli("scan-out-not-las", ["scan", "--scene", "factory:10", "--out", "{out}/scan.ply"], ["a point file ends in .las, .laz or .e57"])
cli("opt-edl-out-of-range", ["render", "--opt", "edl=50", "--out", "{out}"], ["--opt", "edl=", "eye-dome lighting's strength"])
cli("opt-edl-with-points-pipeline", ["render", "--opt", "edl,points-pipeline", "--out", "{out}"],
    ["--opt", "edl shades the compute rasterizer's pixels", "points-pipeline"])

# --- Round 3: readers that must not trust a header with memory ----------------
def bin_file(name, data):
    """Writes a corpus file that a cli case (below it) names."""
    path = os.path.join(OUT, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)


# An E57 of 100 points whose coordinate fields all have minimum == maximum
# (zero bits a record): nothing in the file bounds how many it yields.
bin_file("points/e57-zero-bits.e57", base64.b64decode("QVNUTS1FNTcBAAAAAAAAAAAIAAAAAAAAkAAAAAAAAABwBQAAAAAAAAAEAAAAAAAAAQAAAAAAAABgAAAAAAAAAFAAAAAAAAAAAAAAAAAAAAABAC8AAwAMAAwADAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAABAA8AAwABAAEAAQAAAAAAPD94bWwgdmVyc2lvbj0iMS4wIiBlbmNvZGluZz0iVVRGLTgiPz4KPGU1N1Jvb3QgdHlwZT0iU3RydWN0dXJlIiB4bWxucz0iaHR0cDovL3d3dy5hc3RtLm9yZy9DT01NSVQvRTU3LzIwMTAtZTU3LXYxLjAiPgo8Zm9ybWF0TmFtZSB0eXBlPSJTdHJpbmciPjwhW0NEQVRBW0FTVE0gRTU3IDNEIEltYWdpbmcgRGF0YSBGaWxlXV0+PC9mb3JtYXROYW1lPgo8Z3VpZCB0eXBlPSJTdHJpbmciPjwhW0NEQVRBW3plcm8tYml0c11dPjwvZ3VpZD4KPHZlcnNpb25NYWpvciB0eXBlPSJJbnRlZ2VyIj4xPC92ZXJzaW9uTWFqb3I+Cjx2ZXJzaW9uTWlub3IgdHlwZT0iSW50ZWdlciI+MDwvdmVyc2lvbk1pbm9yPgo8ZTU3TGlicmFyeVZlcnNpb24gdHlwZT0iU3RyaW5nIj48IVtDREFUQVtSdXN0IEU1NyBMaWJyYXJ5IHYwLjExLjEzIGdpdGh1Yi5jb20vY3J5LWluYy9lNTddXT48L2U1N0xpYnJhcnlWZXJzaW9uPgo8ZGF0YTNEIHR5cGU9IlZlY3RvciIgYWxsb3dIZXRlcm9nZW5lb3VzQ2hpbGRyZW49IjEiPgo8dmVjdG9yQ2hpbGQgdHlwZT0iU3RydWN0dXJlIj4KPGd1aWQgdHlwZT0iU3RyaW5nIj48IVtDREFUQVtzY2FuXV0+PC9ndWlkPgo8Y2FydGVzaWFuQm91bmRzIHR5cGU9IlN0cnVjdHVyZSI+Cjx4TWluaW11bSB0eXBlPSJGbG9hdCI+MC4wMDU8L3hNaW5pbXVtPgo8eE1heGltdW0gdHlwZT0iRmxvYXQiPjAuMDA1PC94TWF4aW11bT4KPHlNaW5pbXVtIHR5cGU9IkZsb2F0Ij4wLjAwNTwveU1pbmltdW0+Cjx5TWF4aW11bSB0eXBlPSJGbG9hdCI+MC4wMDU8L3lNYXhpbXVtPgo8ek1pbmltdW0gdHlwZT0iRmxvYXQiPjAuMDA1PC96TWluaW11bT4KPHpNYXhpbXVtIHR5cGU9IkZsb2F0Ij4wLjAwNTwvek1heGltdW0+CjwvY2FydGVzaWFuQm91bmRzDXBu7j4KPHBvaW50cyB0eXBlPSJDb21wcmVzc2VkVmVjdG9yIiBmaWxlT2Zmc2V0PSI0OCIgcmVjb3JkQ291bnQ9IjEwMCI+Cjxwcm90b3R5cGUgdHlwZT0iU3RydWN0dXJlIj4KPGNhcnRlc2lhblggdHlwZT0iU2NhbGVkSW50ZWdlciIgbWluaW11bT0iNSIgbWF4aW11bT0iNSIgc2NhbGU9IjAuMDAxIiBvZmZzZXQ9IjAiPjU8L2NhcnRlc2lhblg+CjxjYXJ0ZXNpYW5ZIHR5cGU9IlNjYWxlZEludGVnZXIiIG1pbmltdW09IjUiIG1heGltdW09IjUiIHNjYWxlPSIwLjAwMSIgb2Zmc2V0PSIwIj41PC9jYXJ0ZXNpYW5ZPgo8Y2FydGVzaWFuWiB0eXBlPSJTY2FsZWRJbnRlZ2VyIiBtaW5pbXVtPSI1IiBtYXhpbXVtPSI1IiBzY2FsZT0iMC4wMDEiIG9mZnNldD0iMCI+NTwvY2FydGVzaWFuWj4KPC9wcm90b3R5cGU+CjwvcG9pbnRzPgo8L3ZlY3RvckNoaWxkPgo8L2RhdGEzRD4KPGltYWdlczJEIHR5cGU9IlZlY3RvciIgYWxsb3dIZXRlcm9nZW5lb3VzQ2hpbGRyZW49IjEiPgo8L2ltYWdlczJEPgo8L2U1N1Jvb3Q+CgAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAjP2yk="))
cli("e57-zero-bits", ["inspect", "{dir}/points/e57-zero-bits.e57"],
    ["e57-zero-bits.e57", "takes no bits"], memory=True)
# The tiny LAZ with an extended VLR (LAS 1.4) claiming 16 GiB.
evlr = bytearray(TINY_LAZ)
struct.pack_into("<QI", evlr, 235, len(TINY_LAZ), 1)
evlr += struct.pack("<H16sHQ32s", 0, b"vergence", 1, 16 << 30, b"")
bin_file("points/evlr-huge.laz", bytes(evlr))
cli("evlr-huge", ["inspect", "{dir}/points/evlr-huge.laz"],
    ["evlr-huge.laz", "extended VLR 0 claims 17179869184 bytes"], memory=True)
# Its laszip VLR listing 4000 extra bytes a point (the decoder builds their
# models before reading a point), the header's record length to match.
VLR = TINY_LAZ.find(b"laszip encoded") - 2
extra = bytearray(TINY_LAZ)
struct.pack_into("<H", extra, 105, 30 + 4000)
struct.pack_into("<HHH", extra, VLR + 54 + 34 + 6, 14, 4000, 3)
bin_file("points/laz-extra-bytes.laz", bytes(extra))
cli("laz-extra-bytes", ["inspect", "{dir}/points/laz-extra-bytes.laz"],
    ["laz-extra-bytes.laz", "4000 extra bytes a point"], memory=True)
# The same with a header-size field of 0: the reader still finds the VLRs
# after the version's whole header, and so does the check.
short_header = bytearray(extra)
struct.pack_into("<H", short_header, 94, 0)
bin_file("points/laz-header-size-zero.laz", bytes(short_header))
cli("laz-header-size-zero", ["inspect", "{dir}/points/laz-header-size-zero.laz"],
    ["laz-header-size-zero.laz", "4000 extra bytes a point"], memory=True)
# A record length the laszip items do not add up to (65535 bytes a point).
long_record = bytearray(TINY_LAZ)
struct.pack_into("<H", long_record, 105, 65535)
bin_file("points/laz-record-length.laz", bytes(long_record))
cli("laz-record-length", ["inspect", "{dir}/points/laz-record-length.laz"],
    ["laz-record-length.laz", "the header's records 65535"], memory=True)
# Outputs that are FIFOs (or devices) are refused, never replaced.
cli("stats-out-fifo", ["run", "--xr", "headless", "--frames", "1", "--stats-out", "{fifo}"],
    ["pipe.gltf", "is a FIFO", "regular files"], memory=True)
cli("scan-noise-huge", ["scan", "--scene", "factory:10", "--noise", "1e6", "--out", "{out}/n.las"],
    ["--noise", "[0, 10]"], memory=True)
cli("scan-rays-product", ["scan", "--scene", "factory:10", "--stations", "10000", "--rays", "100000000",
                          "--out", "{out}/p.las"], ["over the 100000000-ray limit"], memory=True)

# Point files that are not regular files: refused by the file layer before
# a reader opens them (the test makes the FIFOs and the link; see cli()).
cli("points-fifo-ply", ["render", "--scene", "{fifo_ply}", "--out", "{out}"],
    ["pipe.ply", "a FIFO, not a regular file"], memory=True)
cli("points-fifo-las", ["render", "--scene", "{fifo_las}", "--out", "{out}"],
    ["pipe.las", "a FIFO, not a regular file"], memory=True)
cli("points-ply-dev-zero", ["render", "--scene", "{zero_ply}", "--out", "{out}"],
    ["zero.ply", "a character device, not a regular file"], memory=True)
# tune refuses an --out that is its own scene before measuring anything (the
# scene is the 17 MiB sparse big.toml: were the check gone, loading it
# would fail and nothing would be written over it).
cli("tune-out-is-its-scene", ["tune", "--budget-ms", "10", "--frames", "1", "--scene", "{big}",
                              "--out", "{big}"],
    ["--out", "big.toml", "is the scene being tuned"], memory=True)
# A kiosk log named like one of the kiosk's scene files (loaded at start,
# so an input): refused before anything is written.
case("kiosk/log-is-scene.gltf", None, None, gltf())
case("kiosk/log-is-scene.toml", "kiosk", ["log-is-scene.gltf", "is one of this command's inputs"],
     'name = "k"\n[log]\nfile = "log-is-scene.gltf"\n[[scenes]]\nname = "hall"\nscene = "factory:10"\n'
     '[[scenes]]\nname = "tri"\nscene = "log-is-scene.gltf"\n')
# A WebP decompression bomb: a 26-byte lossless WebP whose header claims
# 8192x8192 (256 MiB as RGBA8), used by two images. The first takes the
# whole shared allowance for images beyond 1100:1; the second is refused
# before anything is decoded.
def webp_claiming(w, h):
    bits = (w - 1) | ((h - 1) << 14) | (1 << 28)
    vp8l = b"\x2f" + struct.pack("<I", bits)
    chunk = b"VP8L" + struct.pack("<I", len(vp8l)) + vp8l + b"\0" * (len(vp8l) & 1)
    return b"RIFF" + struct.pack("<I", 4 + len(chunk)) + b"WEBP" + chunk
bin_file("images/webp-bomb.webp", webp_claiming(8192, 8192))
doc = json.loads(textured("webp-bomb.webp"))
doc["extensionsUsed"] = ["EXT_texture_webp"]
doc["images"] = [{"uri": "webp-bomb.webp", "mimeType": "image/webp"}] * 2
doc["textures"] = [{"extensions": {"EXT_texture_webp": {"source": i}}} for i in range(2)]
doc["materials"][0]["emissiveTexture"] = {"index": 1}
case("images/webp-bomb.gltf", "scene",
     ["webp-bomb.webp", "26 encoded bytes claim 268435456 decoded bytes", "a decompression bomb"],
     json.dumps(doc, indent=1))

# A kiosk log that is the kiosk file itself, and a kiosk whose second
# scene is broken: both refused at start, naming the file and the key.
case("kiosk/log-is-kiosk.toml", "kiosk", ["log-is-kiosk.toml", "never writes over an input"],
     'name = "k"\n[log]\nfile = "log-is-kiosk.toml"\n[[scenes]]\nname = "a"\nscene = "factory:10"\n')
case("kiosk/second-scene-broken.toml", "kiosk", ["second-scene-broken.toml", "scenes[1] (annex)", "no-such-annex.gltf"],
     'name = "k"\n[[scenes]]\nname = "hall"\nscene = "factory:10"\n[[scenes]]\nname = "annex"\n'
     'scene = "no-such-annex.gltf"\n')
# raster-floors' default two views on a driver that crashes on an empty
# multiview scope, and a render --out that is a file.
cli("raster-floors-multiview-lavapipe", ["raster-floors", "--width", "64", "--height", "64", "--repeats", "2"],
    ["--views 2", "lavapipe", "--views 1"])
cli("render-out-is-a-file", ["render", "--scene", "factory:10", "--out", "{dir}/cases.toml"],
    ["cases.toml", "is a file, not a folder to write into"])
# Viewpoint files for run --viewpoint: a position out of range, one too
# short, none at all, and a --viewpoint value that is not a pose; good.toml
# is one as `view`'s F8 writes it.
case("viewpoints/good.toml", None, None,
     '\n[[viewpoint]]\nname = "entrance"\nposition = [3.000000, 0.000000, 2.000000]  # the floor under the eyes\n'
     'yaw_deg = -25.000000\n# --pose 3.000000,1.600000,2.000000,-25.000000,0.000000,0.000000\n')
VIEWPOINT = ["run", "--xr", "headless", "--frames", "1", "--mirror", "off", "--viewpoint"]
case("viewpoints/far-position.toml", None, None,
     '[[viewpoint]]\nname = "far"\nposition = [1e300, 0.0, 0.0]\nyaw_deg = 0.0\n')
cli("viewpoints/far-position.toml", VIEWPOINT + ["{dir}/viewpoints/far-position.toml"],
    ["--viewpoint", "far-position.toml", "out of range"])
case("viewpoints/short-position.toml", None, None, '[[viewpoint]]\nname = "x"\nposition = [0.0, 0.0]\n')
cli("viewpoints/short-position.toml", VIEWPOINT + ["{dir}/viewpoints/short-position.toml"],
    ["--viewpoint", "short-position.toml"])
case("viewpoints/empty.toml", None, None, "# no entries\n")
cli("viewpoints/empty.toml", VIEWPOINT + ["{dir}/viewpoints/empty.toml"], ["--viewpoint", "0 viewpoints"])
cli("viewpoint-not-a-pose", VIEWPOINT + ["1,2"], ["--viewpoint", "expected 4 numbers"])

# run --rehearse scripts: refused when read, naming the file, the step and
# the key, before any runtime is reached.
REHEARSE = ["run", "--xr", "openxr", "--frames", "1", "--mirror", "off", "--rehearse"]
def rehearse(name, text, expect):
    case(f"rehearse/{name}.toml", None, None, text)
    cli(f"rehearse-{name}", REHEARSE + [f"{{dir}}/rehearse/{name}.toml"], [f"{name}.toml"] + expect)
rehearse("not-toml", "[[[\n", ["--rehearse"])
rehearse("no-steps", "# nothing\n", ["needs 1 to 10000 [[step]] tables, found 0"])
rehearse("hold-nan", "[[step]]\nhold_s = nan\n", ["step[0].hold_s", "0.001 <= seconds <= 600"])
rehearse("hold-tiny", "[[step]]\nhold_s = 1e-46\n", ["step[0].hold_s", "0.001 <= seconds <= 600"])
rehearse("trigger-big", "[[step]]\nhold_s = 1\n[step.right]\ntrigger = 3\n", ["step[0].right.trigger", "0 to 1"])
rehearse("stick-big", "[[step]]\nhold_s = 1\n[step.left]\nstick = [0, -9]\n", ["step[0].left.stick", "-1 to 1"])
rehearse("head-far", "[[step]]\nhold_s = 1\nhead = { position = [0, 1e300, 0] }\n", ["step[0].head.position"])
rehearse("panel-unknown", "[[step]]\nhold_s = 1\npanel = \"tool:fly\"\n", ["step[0].panel", "unknown panel button 'tool:fly'"])
rehearse("too-long", "[[step]]\nhold_s = 600\n" * 7, ["step[6].hold_s", "runs past 3600 s"])
rehearse("unknown-key", "[[step]]\nhold_s = 1\nwarp = 2\n", ["unknown field `warp`"])
rehearse("name-escape", "[[step]]\nhold_s = 1\nname = \"a\\u001b[2J\"\n", ["step[0].name", "printable"])
cli("desk-controllers-headless", ["run", "--xr", "headless", "--frames", "1", "--desk-controllers"],
    ["--desk-controllers", "--xr openxr", "mirror window"])
cli("rehearse-missing", REHEARSE + ["{dir}/rehearse/nothing-here.toml"], ["--rehearse", "nothing-here.toml"])

with open(os.path.join(OUT, "cases.toml"), "w") as f:
    f.write("# Malformed inputs and the error each must give (tests/bad_inputs.rs runs\n"
            "# them). Written by scripts/make-bad-inputs.py.\n"
            "# kind: scene = vergence inspect FILE; hmd = vergence render --hmd FILE;\n"
            "# plan = vergence bench --plan FILE; config = vergence render --config FILE;\n"
            "# rig = vergence render --rig FILE; kiosk = vergence run --kiosk FILE (headless,\n"
            "# no mirror, one frame); cli = vergence ARGS (file is only a name).\n"
            "# exit: the exit code required (else any failure but a panic); memory: run\n"
            "# under an address-space limit. Every case must end within 10 s.\n")
    for name, kind, expect, extra in cases:
        if kind is None:
            continue
        f.write(f'\n[[case]]\nfile = "{name}"\nkind = "{kind}"\nexpect = {json.dumps(expect, ensure_ascii=False)}\n')
        if extra:
            f.write(f'args = {json.dumps(extra["args"])}\n')
            if extra["exit"] is not None:
                f.write(f'exit = {extra["exit"]}\n')
            if extra["memory"]:
                f.write("memory = true\n")
print(sum(1 for c in cases if c[1]), "cases")
