#!/usr/bin/env python3
"""Writes tests/fixtures/pbr.gltf (and broken/bad_metallic.gltf): two unit quads facing +Z with
each texture kind glTF has for the metallic-roughness model, as data URIs, so that the importer's
test covers them without files beside the fixture.

- Quad "MikkQuad" (no TANGENT: the importer computes MikkTSpace tangents) with material "Metal":
  base colour factor × texture, metallic 1, roughness 0.4 × metallicRoughnessTexture (G) and
  metallic × its B, normalTexture (scale 0.8, KHR_texture_transform), emissiveTexture.
- Quad "TangentQuad" (TANGENT given) with material "Satin": KHR_materials_specular factor 0.5,
  roughness 0.7, metallic 0, a normal map.

Usage: python3 tools/make_pbr_fixture.py   (from the repository root; stdlib only)
"""
import base64, json, os, struct, zlib


def png(width, height, rgba):
    raw = b"".join(b"\x00" + bytes(rgba[y * width * 4:(y + 1) * width * 4]) for y in range(height))
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    body = chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    return "data:image/png;base64," + base64.b64encode(b"\x89PNG\r\n\x1a\n" + body).decode()


# 2×2 images: colour, metallic-roughness (G roughness, B metallic), a normal map tilted towards +u,
# and an emission mask.
COLOR = png(2, 2, [255, 128, 64, 255] * 4)
METAL_ROUGH = png(2, 2, [0, 128, 255, 255] * 4)
NORMAL = png(2, 2, [218, 128, 218, 255] * 4)  # (0.71, 0, 0.71) in [-1, 1]
EMISSIVE = png(2, 2, [255, 255, 255, 255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255, 255])

positions = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
normals = [(0, 0, 1)] * 4
uvs = [(0, 1), (1, 1), (1, 0), (0, 0)]  # u along +x, v along -y (glTF's top-left origin)
# Turned 10° in the plane: a file's own tangents are kept as given (not recomputed).
tangents = [(0.984807753, 0.173648178, 0, -1)] * 4
indices = [0, 1, 2, 0, 2, 3]

blob = b"".join(struct.pack("<3f", *p) for p in positions)
blob += b"".join(struct.pack("<3f", *n) for n in normals)
blob += b"".join(struct.pack("<2f", *t) for t in uvs)
blob += b"".join(struct.pack("<4f", *t) for t in tangents)
blob += b"".join(struct.pack("<H", i) for i in indices) + b"\x00\x00"
views = [(0, 48), (48, 48), (96, 32), (128, 64), (192, 12)]


def quad(material, with_tangents):
    attributes = {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}
    if with_tangents:
        attributes["TANGENT"] = 3
    return {"primitives": [{"attributes": attributes, "indices": 4, "material": material}]}


def document(metallic_factor):
    return {
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_specular"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"name": "MikkQuad", "mesh": 0}, {"name": "TangentQuad", "mesh": 1, "translation": [3, 0, 0]}],
        "meshes": [dict(quad(0, False), name="MikkQuad"), dict(quad(1, True), name="TangentQuad")],
        "materials": [
            {
                "name": "Metal",
                "pbrMetallicRoughness": {
                    "baseColorFactor": [0.9, 0.6, 0.3, 1.0],
                    "baseColorTexture": {"index": 0},
                    "metallicFactor": metallic_factor,
                    "roughnessFactor": 0.4,
                    "metallicRoughnessTexture": {"index": 1},
                },
                "normalTexture": {
                    "index": 2,
                    "scale": 0.8,
                    "extensions": {"KHR_texture_transform": {"offset": [0.25, 0.5], "scale": [2.0, 2.0]}},
                },
                "emissiveTexture": {"index": 3},
                "emissiveFactor": [1.0, 1.0, 1.0],
            },
            {
                "name": "Satin",
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7},
                "normalTexture": {"index": 2},
                "extensions": {"KHR_materials_specular": {"specularFactor": 0.5}},
            },
        ],
        "textures": [{"source": i} for i in range(4)],
        "images": [{"name": n, "uri": u} for n, u in [("color", COLOR), ("metal_rough", METAL_ROUGH), ("normal", NORMAL), ("emissive", EMISSIVE)]],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }


root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "fixtures")
with open(os.path.join(root, "pbr.gltf"), "w") as f:
    json.dump(document(1.0), f, indent=1)
with open(os.path.join(root, "broken", "bad_metallic.gltf"), "w") as f:
    json.dump(document(2.0), f, indent=1)
