"""Write lab_room.glb: a small real glTF 2.0 model, written by trimesh's exporter.

No installed package ships a .glb or .gltf file (checked in .venv/lib/python3.11/site-packages),
so the lab's "real model" test (tests/scenes/test_gltf.py) reads this one: its bytes come from
trimesh.exchange.gltf.export_glb (an independent writer: node matrices, uint32 indices,
baseColorFactor quantised to 8-bit steps, metallic and roughness factors), with the KHR_lights_punctual lights and the camera
added to the exported tree by `tree_postprocessor` (trimesh writes neither).

    .venv/bin/python scenes/data/make_lab_room.py      # rewrites scenes/data/lab_room.glb

A 20 x 20 m floor, columns, boxes, a sphere and a torus (about 2,000 triangles; rough
dielectrics, a glossy sphere and a metal torus); eight point
lights without range (their radius comes from the cutoff rule), two spot lights with range,
one directional light (skipped by the loader, with its warning line) and a perspective camera
looking into the room.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh
from trimesh.exchange.gltf import export_glb
from trimesh.transformations import quaternion_from_matrix, rotation_matrix, translation_matrix

OUT = Path(__file__).with_name("lab_room.glb")


def _material(rgb, roughness, metallic):
    return trimesh.visual.TextureVisuals(material=trimesh.visual.material.PBRMaterial(
        baseColorFactor=[*rgb, 1.0], roughnessFactor=roughness, metallicFactor=metallic))


# trimesh builds cylinders and tori around +Z: stood up (+Z to +Y) by this node rotation
UPRIGHT = rotation_matrix(-math.pi / 2, (1.0, 0.0, 0.0))


def _add(scene, mesh, rgb, name, t=(0.0, 0.0, 0.0), upright=False, roughness=0.8, metallic=0.0):
    mesh.visual = _material(rgb, roughness, metallic)
    m = translation_matrix(t) @ (UPRIGHT if upright else np.eye(4))
    scene.add_geometry(mesh, node_name=name, geom_name=name, transform=m)


def room() -> trimesh.Scene:
    s = trimesh.Scene()
    floor = trimesh.creation.box(extents=(20.0, 0.1, 20.0))
    _add(s, floor, (0.62, 0.6, 0.56), "floor", (0.0, -0.05, 0.0))
    for k, (x, z) in enumerate([(-6, -6), (6, -6), (-6, 2), (6, 2)]):
        _add(s, trimesh.creation.cylinder(radius=0.5, height=5.0, sections=24), (0.8, 0.78, 0.74),
             f"column{k}", (x, 2.5, z), upright=True)
    _add(s, trimesh.creation.box(extents=(3.0, 1.5, 2.0)), (0.7, 0.3, 0.25), "crate", (-2.5, 0.75, -3.0))
    _add(s, trimesh.creation.box(extents=(1.5, 3.0, 1.5)), (0.25, 0.45, 0.7), "tower", (3.0, 1.5, -1.0))
    _add(s, trimesh.creation.icosphere(subdivisions=3, radius=1.2), (0.9, 0.9, 0.85), "sphere", (0.0, 1.2, 1.5),
         roughness=0.3)
    _add(s, trimesh.creation.torus(major_radius=1.5, minor_radius=0.3, major_sections=32, minor_sections=12),
         (0.35, 0.65, 0.35), "torus", (-4.0, 0.3, 5.0), upright=True, roughness=0.4, metallic=1.0)
    return s


def _look_rotation(eye, target, up=(0.0, 1.0, 0.0)):
    """glTF quaternion [x, y, z, w] turning a node's -Z towards target - eye, +Y towards up."""
    f = np.subtract(target, eye).astype(float)
    f /= np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = r, u, -f
    w, x, y, z = quaternion_from_matrix(m)
    return [float(x), float(y), float(z), float(w)]


def add_lights_and_camera(tree: dict) -> None:
    lights = []
    nodes = tree.setdefault("nodes", [])
    roots = tree["scenes"][0].setdefault("nodes", [])

    def node(**kw):
        nodes.append(kw)
        roots.append(len(nodes) - 1)

    palette = [(1.0, 0.75, 0.45), (0.55, 0.75, 1.0), (1.0, 0.9, 0.8), (0.8, 1.0, 0.7)]
    for k in range(8):
        a = 2 * math.pi * k / 8
        lights.append({"type": "point", "color": list(palette[k % 4]), "intensity": 6.0 + 3.0 * (k % 3),
                       "name": f"bulb{k}"})
        node(name=f"bulb{k}", translation=[7.5 * math.cos(a), 0.6 + 0.4 * (k % 3), 7.5 * math.sin(a)],
             extensions={"KHR_lights_punctual": {"light": len(lights) - 1}})
    for k, (eye, target) in enumerate([((-3.0, 6.0, 4.0), (-2.5, 0.0, -3.0)), ((4.0, 6.0, 3.0), (0.0, 0.0, 1.5))]):
        lights.append({"type": "spot", "color": [1.0, 0.95, 0.85], "intensity": 40.0, "range": 12.0,
                       "spot": {"innerConeAngle": 0.15, "outerConeAngle": 0.45}, "name": f"spot{k}"})
        node(name=f"spot{k}", translation=list(eye), rotation=_look_rotation(eye, target),
             extensions={"KHR_lights_punctual": {"light": len(lights) - 1}})
    lights.append({"type": "directional", "intensity": 2.0, "name": "sun"})
    node(name="sun", rotation=_look_rotation((0, 0, 0), (0.3, -1.0, -0.2), up=(0.0, 0.0, -1.0)),
         extensions={"KHR_lights_punctual": {"light": len(lights) - 1}})
    tree.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": lights}
    tree.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
    tree["cameras"] = [{"type": "perspective", "name": "view",
                        "perspective": {"yfov": math.radians(50.0), "znear": 0.1, "zfar": 100.0}}]
    eye = (0.0, 7.0, 16.0)
    node(name="camera", camera=0, translation=list(eye), rotation=_look_rotation(eye, (0.0, 0.5, 0.0)))


def main() -> None:
    data = export_glb(room(), include_normals=False, tree_postprocessor=add_lights_and_camera)
    OUT.write_bytes(data)
    print(f"wrote {OUT} ({len(data)} bytes)")


if __name__ == "__main__":
    main()
