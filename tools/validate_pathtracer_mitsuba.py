#!/usr/bin/env python3
"""Checks the project's path tracer against an independent renderer, Mitsuba 3.

Renders the OBJ Cornell box of tests/fixtures (classic measurements, one area light) with Mitsuba's
unidirectional path tracer from the original setup's camera, and compares the result with
`game_demo render --mode pathtrace`'s linear EXR: mean radiance per channel and 16×16-pixel block
means (which average most of both renderers' noise away).

Usage (Mitsuba and numpy from PyPI: `pip install mitsuba numpy`):
    game_demo render --scene tests/fixtures/cornell_box.obj --mode pathtrace --spp 512 \
        --width 128 --height 128 --camera-position 0.278,0.273,-0.8 --camera-target 0.278,0.273,0 \
        --fov 39.3 --out out/validate
    python3 tools/validate_pathtracer_mitsuba.py out/validate/image.exr [--spp 512]
    # Glossy paths: the same with tests/fixtures/cornell_box_glossy.obj (rough metal blocks), and
    python3 tools/validate_pathtracer_mitsuba.py out/validate_glossy/image.exr --obj tests/fixtures/cornell_box_glossy.obj

Both renderers here treat surfaces as two-sided (Mitsuba's `twosided` BSDF), the light quad as a
one-sided area emitter of radiance Ke, and paths as unbounded (Russian roulette). Diffuse
materials are Lambertian; materials with the MTL PBR extension's `Pm 1` are GGX metals of
roughness `Pr` (α = Pr²) and reflectance Kd: Mitsuba's `roughconductor` with a perfect mirror's
Fresnel scaled by Kd, where ours follows Schlick's curve from Kd towards 1 at grazing angles and
gives back the energy single scattering loses (under 1% of it at these roughnesses).
"""
import argparse
import os
import sys
import tempfile

import numpy as np
import mitsuba as mi

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OBJ = os.path.join(ROOT, "tests", "fixtures", "cornell_box.obj")


def read_mtl(path):
    materials, current = {}, None
    for line in open(path):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "newmtl":
            current = materials.setdefault(parts[1], {"Kd": [0, 0, 0], "Ke": [0, 0, 0], "Pm": 0.0, "Pr": 1.0})
        elif parts[0] in ("Kd", "Ke") and current is not None:
            current[parts[0]] = [float(x) for x in parts[1:4]]
        elif parts[0] in ("Pm", "Pr") and current is not None:
            current[parts[0]] = float(parts[1])
    return materials


def read_obj(path):
    """Objects as (name, material, vertices, triangles)."""
    positions, objects = [], []
    for line in open(path):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "o":
            objects.append({"name": parts[1], "material": None, "faces": []})
        elif parts[0] == "v":
            positions.append([float(x) for x in parts[1:4]])
        elif parts[0] == "usemtl":
            objects[-1]["material"] = parts[1]
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) - 1 for p in parts[1:]]
            for k in range(1, len(idx) - 1):
                objects[-1]["faces"].append((idx[0], idx[k], idx[k + 1]))
    return np.array(positions), objects


# The original Cornell box camera (metres), as given to game_demo on the command line.
CAMERA_POSITION = np.array([0.278, 0.273, -0.8])
CAMERA_TARGET = np.array([0.278, 0.273, 0.0])
CAMERA_FOV = 39.3


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("ours", help="linear EXR from game_demo render --mode pathtrace")
    parser.add_argument("--spp", type=int, default=512)
    parser.add_argument("--obj", default=OBJ, help="the OBJ fixture (its mtllib beside it)")
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    ours = np.array(mi.Bitmap(args.ours).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))
    height, width = ours.shape[:2]

    positions, objects = read_obj(args.obj)
    mtllib = next(l.split()[1] for l in open(args.obj) if l.startswith("mtllib"))
    materials = read_mtl(os.path.join(os.path.dirname(os.path.abspath(args.obj)), mtllib))
    eye, target, fov = CAMERA_POSITION, CAMERA_TARGET, CAMERA_FOV
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective",
            "fov": fov,
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=eye.tolist(), target=target.tolist(), up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": args.spp},
        },
    }
    tmp = tempfile.mkdtemp()
    for obj in objects:
        path = os.path.join(tmp, obj["name"] + ".obj")
        with open(path, "w") as f:
            for p in positions:
                f.write("v %f %f %f\n" % tuple(p))
            for a, b, c in obj["faces"]:
                f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
        m = materials[obj["material"]]
        if m["Pm"] > 0.5:
            surface = {
                "type": "roughconductor",
                "distribution": "ggx",
                "alpha": max(m["Pr"], 0.045) ** 2,
                "material": "none",
                "specular_reflectance": {"type": "rgb", "value": m["Kd"]},
            }
        else:
            surface = {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["Kd"]}}
        shape = {"type": "obj", "filename": path, "face_normals": True, "bsdf": {"type": "twosided", "bsdf": surface}}
        if any(v > 0 for v in m["Ke"]):
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": m["Ke"]}}
        scene[obj["name"]] = shape
    reference = np.array(mi.render(mi.load_dict(scene)))[:, :, :3]

    mean_ours, mean_ref = ours.reshape(-1, 3).mean(axis=0), reference.reshape(-1, 3).mean(axis=0)
    block = 16
    def blocks(img):
        return img[: height // block * block, : width // block * block].reshape(height // block, block, width // block, block, 3).mean(axis=(1, 3))
    bo, br = blocks(ours), blocks(reference)
    lit = br.mean(axis=2) > 0.05 * br.mean()
    rel = np.abs(bo - br)[lit] / np.maximum(br[lit], 1e-3)
    print(f"image mean radiance: ours {mean_ours}, Mitsuba {mean_ref}, ratio {mean_ours / mean_ref}")
    print(f"{block}x{block} block means (lit blocks): median relative difference {np.median(rel):.4f}, 90th percentile {np.percentile(rel, 90):.4f}")
    ok = np.all(np.abs(mean_ours / mean_ref - 1) < 0.03) and np.median(rel) < 0.05
    print("AGREE within noise" if ok else "DISAGREE")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
