#!/usr/bin/env python3
"""Makes the loader tests' KTX2 images (builder/src/load/testdata) and the glTF
fuzzing seed that carries one (fuzz/seeds/gltf/ktx2.gltf).

The images are a 16 x 16 texture of four flat 8 x 8 quadrants, coded by the
Basis Universal encoder (PyPI's `alktx2`, which wraps it): ETC1S blocks with
BasisLZ, and UASTC blocks with zstd supercompression. Run from the repository:

    python3 -m venv /tmp/kv && /tmp/kv/bin/pip install alktx2
    /tmp/kv/bin/python scripts/ktx2_fixtures.py
"""
import base64
import json
import struct

import alktx2

QUADRANTS = [(200, 40, 30), (30, 160, 60), (40, 70, 220), (240, 230, 200)]  # as the tests' QUADRANTS
raw = bytearray()
for y in range(16):
    for x in range(16):
        raw += bytes(QUADRANTS[x // 8 + 2 * (y // 8)]) + b"\xff"
images = {
    "quadrants_etc1s.ktx2": alktx2.encode_raw_rgba_to_ktx2(bytes(raw), 16, 16, False, codec="etc1s"),
    "quadrants_uastc_zstd.ktx2": alktx2.encode_raw_rgba_to_ktx2(bytes(raw), 16, 16, False, codec="uastc", zstd_supercompression_level=6),
}
for name, data in images.items():
    open(f"builder/src/load/testdata/{name}", "wb").write(data)

# A textured quad whose texture is given only by KHR_texture_basisu.
positions = [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]
uvs = [0, 1, 1, 1, 1, 0, 0, 0]
indices = [0, 1, 2, 0, 2, 3]
data = struct.pack("<12f", *positions) + struct.pack("<8f", *uvs) + struct.pack("<6H", *indices)
gltf = {
    "asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
    "extensionsUsed": ["KHR_texture_basisu"], "extensionsRequired": ["KHR_texture_basisu"],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "textures": [{"extensions": {"KHR_texture_basisu": {"source": 0}}}],
    "images": [{"uri": "data:image/ktx2;base64," + base64.b64encode(images["quadrants_etc1s.ktx2"]).decode()}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ],
    "bufferViews": [{"buffer": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 32}, {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
    "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
}
open("fuzz/seeds/gltf/ktx2.gltf", "w").write(json.dumps(gltf))
