"""Transparent geometry in scene files (docs/contracts.md "Contract: scene files", Additions):
`opacity` on a box or mesh entry, glTF's alphaMode BLEND, and the builtin city-glass."""
from __future__ import annotations

import base64
import json

import numpy as np
import pytest

from scenes import SceneError, load_scene, scene_from_dict
from scenes.geometry import box_mesh, merge_meshes


def scene(*geometry) -> dict:
    return {"resolution": [32, 24],
            "camera": {"position": [0, 2, 10], "target": [0, 1, 0]},
            "geometry": list(geometry),
            "lights": [{"type": "point", "position": [0, 1, 0], "radius": 3}]}


FLOOR = {"box": {"min": [-20, -0.1, -20], "max": [20, 0, 20]}}
PANE = {"box": {"min": [-2, 0, 2], "max": [2, 3, 2.1]}, "albedo": [0.5, 0.7, 0.9]}


def test_opacity_is_read_and_defaults_to_opaque(tmp_path):
    (tmp_path / "tri.obj").write_text("v -1 0 -1\nv 1 0 -1\nv 0 1 -1\nf 1 2 3\n")
    s = scene_from_dict(scene(FLOOR, dict(PANE, opacity=0.3),
                              {"mesh": "tri.obj", "opacity": 0.0}), tmp_path)
    floor, pane, tri = s.meshes
    assert (floor.opacity, floor.transparent) == (1.0, False)
    assert (pane.opacity, pane.transparent) == (0.3, True)
    assert (tri.opacity, tri.transparent) == (0.0, True)
    assert s.opaque_meshes() == [floor] and s.transparent_meshes() == [pane, tri]
    assert scene_from_dict(scene(FLOOR, dict(PANE, opacity=1))).transparent_meshes() == []


@pytest.mark.parametrize("value", [1.5, -0.25, 1.0000001, "glass", None, float("nan")])
def test_opacity_outside_zero_one_is_one_line_naming_the_entry(value):
    with pytest.raises(SceneError) as exc:
        scene_from_dict(scene(FLOOR, dict(PANE, opacity=value)), source_name="s.json")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("s.json: geometry[1].opacity: "), msg


def test_merging_keeps_transparent_and_opaque_apart():
    a, b = box_mesh((0, 0, 0), (1, 1, 1)), box_mesh((2, 0, 0), (3, 1, 1))
    b.opacity = 0.4
    c = box_mesh((4, 0, 0), (5, 1, 1))
    merged = merge_meshes([a, b, c])
    assert [m.opacity for m in merged] == [1.0, 0.4]
    assert [len(m.faces) for m in merged] == [len(a.faces) + len(c.faces), len(b.faces)]


def gltf_file(path, materials: list[dict]):
    """A glTF of one triangle per material, side by side."""
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    data = b"".join((tri + [2.0 * k, 0, 0]).astype(np.float32).tobytes() for k in range(len(materials)))
    h = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(materials)))}],
         "nodes": [{"mesh": k} for k in range(len(materials))],
         "meshes": [{"primitives": [{"attributes": {"POSITION": k}, "material": k}]}
                    for k in range(len(materials))],
         "materials": materials,
         "accessors": [{"bufferView": 0, "byteOffset": 36 * k, "componentType": 5126, "count": 3,
                        "type": "VEC3", "min": [2.0 * k, 0, 0], "max": [2.0 * k + 1, 1, 0]}
                       for k in range(len(materials))],
         "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
         "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                      + base64.b64encode(data).decode()}]}
    path.write_text(json.dumps(h))
    return path


def pbr(alpha, **kw):
    return dict(kw, pbrMetallicRoughness={"baseColorFactor": [0.2, 0.4, 0.6, alpha]})


def test_gltf_blend_takes_its_base_colour_alpha_as_opacity(tmp_path):
    p = gltf_file(tmp_path / "s.gltf", [pbr(0.25, alphaMode="BLEND"), pbr(0.5), pbr(0.5, alphaMode="MASK"),
                                        pbr(0.75, alphaMode="OPAQUE")])
    s = load_scene(str(p))
    assert sorted(m.opacity for m in s.meshes) == [0.25, 1.0]        # merged: the three opaque ones
    blend = next(m for m in s.meshes if m.transparent)
    assert len(blend.faces) == 1 and np.allclose(blend.vertices[:, 0].min(), 0.0)


def test_gltf_unknown_alpha_mode_is_one_line(tmp_path):
    p = gltf_file(tmp_path / "s.gltf", [pbr(0.5), pbr(0.5, alphaMode="ADD")])
    with pytest.raises(SceneError) as exc:
        load_scene(str(p))
    msg = str(exc.value)
    assert "\n" not in msg and "materials[1].alphaMode" in msg and "ADD" in msg, msg


def test_city_glass_is_city_with_transparent_panes_and_particles():
    city, glass = load_scene("city", lights=64), load_scene("city-glass", lights=64)
    assert glass.name == "city-glass" and glass.lights.tobytes() == city.lights.tobytes()
    assert glass.camera == city.camera and glass.max_depth == city.max_depth
    assert len(glass.opaque_meshes()) == len(city.meshes)
    for a, b in zip(glass.opaque_meshes(), city.meshes):
        assert np.array_equal(a.vertices, b.vertices) and a.material == b.material
    assert city.transparent_meshes() == []
    opacities = sorted({m.opacity for m in glass.transparent_meshes()})
    assert len(opacities) == 2 and 0 < opacities[0] < opacities[1] < 1     # panes, particles
