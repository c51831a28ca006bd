"""JSON scene loading: strict validation (one-line errors naming the field) and a round trip."""
import json
import math

import numpy as np
import pytest
import trimesh

from scenes import LIGHT_DTYPE, SceneError, load_scene
from scenes.loader import MAX_LIGHTS, scene_from_dict

NPZ_KEYS = ("type", "position", "radius", "color", "intensity", "direction", "cos_inner", "cos_outer")


def good_dict():
    return {
        "resolution": [320, 180],
        "camera": {"position": [0, 2, 10], "target": [0, 2, 0], "up": [0, 1, 0],
                   "fov_y_deg": 60, "near": 0.1, "far": 1000},
        "geometry": [{"box": {"min": [-50, -0.1, -50], "max": [50, 0, 50]}, "albedo": [0.8, 0.8, 0.8]}],
        "lights": [
            {"type": "point", "position": [0, 1, 0], "radius": 3, "color": [1, 0.9, 0.8], "intensity": 5},
            {"type": "spot", "position": [2, 4, 0], "direction": [0, -2, 0], "radius": 10,
             "inner_angle_deg": 20, "outer_angle_deg": 30, "color": [1, 1, 1], "intensity": 20},
        ],
    }


def npz_arrays(n=3):
    return {
        "type": np.array([0, 1, 0][:n] + [0] * max(0, n - 3), np.uint8),
        "position": np.arange(3 * n, dtype=np.float32).reshape(n, 3),
        "radius": np.full(n, 2.5, np.float32),
        "color": np.full((n, 3), 0.5, np.float32),
        "intensity": np.full(n, 4.0, np.float32),
        "direction": np.tile(np.array([[0, 0, -3]], np.float32), (n, 1)),
        "cos_inner": np.full(n, 0.95, np.float32),
        "cos_outer": np.full(n, 0.9, np.float32),
    }


def write_npz(tmp_path, arrays, name="lights.npz"):
    np.savez(tmp_path / name, **arrays)
    return name


def with_mesh(d, tmp_path, mesh_name="m.obj", **extra):
    trimesh.creation.box(extents=(1, 1, 1)).export(tmp_path / "m.obj")
    d["geometry"].append({"mesh": mesh_name, **extra})


def with_npz(d, tmp_path, **changes):
    a = npz_arrays()
    for k, v in changes.items():
        if v is None:
            del a[k]
        else:
            a[k] = v
    d["lights_npz"] = write_npz(tmp_path, a)


def _set(path, value):
    def f(d, tmp_path):
        obj = d
        for k in path[:-1]:
            obj = obj[k]
        if value is _DEL:
            del obj[path[-1]]
        else:
            obj[path[-1]] = value
    return f


_DEL = object()
NAN = float("nan")
INF = float("inf")


def _bad_npz_type_count(d, tmp_path):
    a = npz_arrays()
    a["type"] = np.zeros(MAX_LIGHTS, np.uint8)          # only the count matters: checked first
    np.savez_compressed(tmp_path / "big.npz", **a)
    d["lights_npz"] = "big.npz"


def _garbage_npz(d, tmp_path):
    (tmp_path / "bad.npz").write_bytes(b"not a zip archive at all")
    d["lights_npz"] = "bad.npz"


def _empty_mesh(d, tmp_path):
    (tmp_path / "empty.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    d["geometry"].append({"mesh": "empty.obj"})


def _unreadable_mesh(d, tmp_path):
    (tmp_path / "m.unknownformat").write_bytes(b"\x00\x01\x02")
    d["geometry"].append({"mesh": "m.unknownformat"})


# (case id, mutation(d, tmp_path), text the one-line message must contain)
BAD = [
    # top level / required keys
    ("missing_resolution", _set(["resolution"], _DEL), "resolution: missing"),
    ("missing_camera", _set(["camera"], _DEL), "camera: missing"),
    ("missing_camera_position", _set(["camera", "position"], _DEL), "camera.position: missing"),
    ("missing_camera_target", _set(["camera", "target"], _DEL), "camera.target: missing"),
    ("missing_lights", _set(["lights"], _DEL), "lights: missing"),
    ("geometry_not_list", _set(["geometry"], {"box": 1}), "geometry:"),
    ("lights_not_list", _set(["lights"], "many"), "lights:"),
    ("light_not_object", _set(["lights", 0], 7), "lights[0]:"),
    ("geometry_entry_box_and_mesh", _set(["geometry", 0, "mesh"], "x.obj"), "geometry[0]:"),
    ("camera_not_object", _set(["camera"], [0, 1, 2]), "camera:"),
    # wrong types
    ("resolution_string", _set(["resolution"], "960x540"), "resolution:"),
    ("resolution_float", _set(["resolution"], [960.5, 540]), "resolution[0]:"),
    ("resolution_three", _set(["resolution"], [960, 540, 1]), "resolution:"),
    ("resolution_zero", _set(["resolution"], [0, 540]), "resolution[0]:"),
    ("resolution_huge", _set(["resolution"], [960, 20000]), "resolution[1]:"),
    ("radius_string", _set(["lights", 0, "radius"], "3"), "lights[0].radius:"),
    ("radius_bool", _set(["lights", 0, "radius"], True), "lights[0].radius:"),
    ("position_two", _set(["camera", "position"], [0, 1]), "camera.position:"),
    ("light_position_string", _set(["lights", 0, "position"], ["a", 0, 0]), "lights[0].position[0]:"),
    # NaN / inf anywhere
    ("nan_radius", _set(["lights", 1, "radius"], NAN), "lights[1].radius:"),
    ("inf_camera_position", _set(["camera", "position"], [INF, 0, 0]), "camera.position[0]:"),
    ("nan_unknown_key", _set(["extra"], [1, NAN]), "extra[1]:"),
    ("nan_albedo", _set(["geometry", 0, "albedo"], [NAN, 0, 0]), "geometry[0].albedo[0]:"),
    ("overflow_intensity", _set(["lights", 0, "intensity"], 1e39), "lights[0].intensity:"),
    # camera
    ("fov_zero", _set(["camera", "fov_y_deg"], 0), "camera.fov_y_deg:"),
    ("fov_180", _set(["camera", "fov_y_deg"], 180), "camera.fov_y_deg:"),
    ("near_zero", _set(["camera", "near"], 0), "camera.near:"),
    ("near_negative", _set(["camera", "near"], -1), "camera.near:"),
    ("far_le_near", _set(["camera", "far"], 0.1), "camera.far:"),
    ("far_near_absurd", _set(["camera", "near"], 1e-7), "camera.far:"),
    ("position_eq_target", _set(["camera", "target"], [0, 2, 10]), "camera.target:"),
    ("up_parallel", _set(["camera", "up"], [0, 0, 5]), "camera.up:"),
    ("up_zero", _set(["camera", "up"], [0, 0, 0]), "camera.up:"),
    # lights
    ("unknown_light_type", _set(["lights", 0, "type"], "area"), "lights[0].type:"),
    ("missing_light_type", _set(["lights", 0, "type"], _DEL), "lights[0].type:"),
    ("missing_radius", _set(["lights", 0, "radius"], _DEL), "lights[0].radius:"),
    ("radius_negative", _set(["lights", 0, "radius"], -1.0), "lights[0].radius:"),
    ("radius_zero", _set(["lights", 0, "radius"], 0), "lights[0].radius:"),
    ("radius_huge", _set(["lights", 0, "radius"], 2e7), "lights[0].radius:"),
    ("color_negative", _set(["lights", 0, "color"], [1, -0.1, 1]), "lights[0].color[1]:"),
    ("intensity_negative", _set(["lights", 0, "intensity"], -5), "lights[0].intensity:"),
    ("spot_direction_zero", _set(["lights", 1, "direction"], [0, 0, 0]), "lights[1].direction:"),
    ("spot_direction_missing", _set(["lights", 1, "direction"], _DEL), "lights[1].direction:"),
    ("spot_outer_90", _set(["lights", 1, "outer_angle_deg"], 90), "lights[1].outer_angle_deg:"),
    ("spot_inner_zero", _set(["lights", 1, "inner_angle_deg"], 0), "lights[1].inner_angle_deg:"),
    ("spot_inner_gt_outer", _set(["lights", 1, "inner_angle_deg"], 40), "lights[1].inner_angle_deg:"),
    # geometry
    ("box_min_gt_max", _set(["geometry", 0, "box", "min"], [60, -0.1, -50]), "geometry[0].box.min:"),
    ("box_missing_max", _set(["geometry", 0, "box", "max"], _DEL), "geometry[0].box.max:"),
    ("albedo_gt_one", _set(["geometry", 0, "albedo"], [2, 0, 0]), "geometry[0].albedo[0]:"),
    ("mesh_missing_file", lambda d, t: d["geometry"].append({"mesh": "nope.obj"}), "geometry[1].mesh:"),
    ("mesh_unreadable", lambda d, t: _unreadable_mesh(d, t), "geometry[1].mesh:"),
    ("mesh_no_faces", lambda d, t: _empty_mesh(d, t), "geometry[1].mesh:"),
    ("transform_3x3", lambda d, t: with_mesh(d, t, transform=np.eye(3).tolist()),
     "geometry[1].transform:"),
    ("transform_nan", lambda d, t: with_mesh(d, t, transform=[[NAN, 0, 0, 0], [0, 1, 0, 0],
                                                              [0, 0, 1, 0], [0, 0, 0, 1]]),
     "geometry[1].transform[0][0]:"),
    ("transform_not_affine", lambda d, t: with_mesh(d, t, transform=[[1, 0, 0, 0], [0, 1, 0, 0],
                                                                     [0, 0, 1, 0], [5, 0, 0, 1]]),
     "geometry[1].transform[3]:"),
    # npz
    ("npz_missing_file", _set(["lights_npz"], "nope.npz"), "lights_npz:"),
    ("npz_unreadable", lambda d, t: _garbage_npz(d, t), "lights_npz:"),
    ("npz_missing_array", lambda d, t: with_npz(d, t, cos_outer=None), "lights_npz.cos_outer:"),
    ("npz_inconsistent_length", lambda d, t: with_npz(d, t, radius=np.ones(4, np.float32)),
     "lights_npz.radius:"),
    ("npz_bad_type", lambda d, t: with_npz(d, t, type=np.array([0, 2, 0], np.uint8)), "lights_npz.type[1]:"),
    ("npz_float_type", lambda d, t: with_npz(d, t, type=np.zeros(3, np.float32)), "lights_npz.type:"),
    ("npz_radius_zero", lambda d, t: with_npz(d, t, radius=np.array([1, 0, 1], np.float32)),
     "lights_npz.radius[1]:"),
    ("npz_position_nan", lambda d, t: with_npz(d, t, position=np.array([[0, 0, 0], [0, NAN, 0], [0, 0, 0]],
                                                                       np.float32)),
     "lights_npz.position[1]:"),
    ("npz_color_negative", lambda d, t: with_npz(d, t, color=-np.ones((3, 3), np.float32)),
     "lights_npz.color[0]:"),
    ("npz_intensity_negative", lambda d, t: with_npz(d, t, intensity=np.array([1, 1, -1], np.float32)),
     "lights_npz.intensity[2]:"),
    ("npz_spot_direction_zero", lambda d, t: with_npz(d, t, direction=np.zeros((3, 3), np.float32)),
     "lights_npz.direction[1]:"),
    ("npz_spot_inner_gt_outer", lambda d, t: with_npz(d, t, cos_inner=np.full(3, 0.5, np.float32)),
     "lights_npz.cos_inner[1]:"),
    ("npz_spot_cos_out_of_range", lambda d, t: with_npz(d, t, cos_outer=np.full(3, -0.5, np.float32)),
     "lights_npz.cos_outer[1]:"),
    ("total_light_count", lambda d, t: _bad_npz_type_count(d, t), "lights_npz:"),
]


@pytest.mark.parametrize("mutate, field", [pytest.param(m, f, id=i) for i, m, f in BAD])
def test_bad_field_rejected(tmp_path, mutate, field):
    d = good_dict()
    mutate(d, tmp_path)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(d))            # NaN/Infinity are written as literals
    with pytest.raises(SceneError) as ei:
        load_scene(str(path))
    msg = str(ei.value)
    assert "\n" not in msg and "\r" not in msg
    assert msg.startswith(f"{path}: "), msg
    assert field in msg, msg


@pytest.mark.parametrize("text, field", [
    pytest.param('{"resolution": [960, 540],\n "camera": {', "line 2 col", id="malformed_json"),
    pytest.param('{"a": 1,}', "line 1 col", id="trailing_comma"),
    pytest.param("[1, 2, 3]", "top level:", id="top_level_array"),
    pytest.param('"scene"', "top level:", id="top_level_string"),
])
def test_bad_file_rejected(tmp_path, text, field):
    path = tmp_path / "scene.json"
    path.write_text(text)
    with pytest.raises(SceneError) as ei:
        load_scene(str(path))
    msg = str(ei.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ") and field in msg, msg


def test_unknown_name_rejected():
    with pytest.raises(SceneError) as ei:
        load_scene("no-such-scene-or-file")
    assert "\n" not in str(ei.value) and "city" in str(ei.value)


def test_scene_from_dict_validates_without_files():
    d = good_dict()
    d["lights"][0]["radius"] = -1.0
    with pytest.raises(SceneError, match=r"^mem: lights\[0\]\.radius: .*\(got -1\.0\)$"):
        scene_from_dict(d, None, "mem")
    assert isinstance(SceneError("x"), ValueError)


def test_good_scene_round_trip(tmp_path):
    d = good_dict()
    (tmp_path / "sub").mkdir()
    trimesh.creation.box(extents=(2, 2, 2)).export(tmp_path / "sub" / "cube.obj")
    d["geometry"].append({"mesh": "sub/cube.obj",
                          "transform": [[1, 0, 0, 5], [0, 1, 0, 1], [0, 0, 1, -3], [0, 0, 0, 1]],
                          "albedo": [0.2, 0.4, 0.6]})
    d["unknown_key_is_ignored"] = {"anything": [1, 2]}
    a = npz_arrays()
    d["lights_npz"] = write_npz(tmp_path, a, "sub/../l.npz")
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(d))

    s = load_scene(str(path), seed=123, distribution="whatever-ignored")
    assert s.name == "scene"
    assert s.resolution == (320, 180)
    assert s.camera.position == (0.0, 2.0, 10.0) and s.camera.far == 1000.0
    assert len(s.meshes) == 2
    box, cube = s.meshes
    assert box.vertices.dtype == np.float32 and box.faces.dtype == np.int32 and len(box.faces) == 12
    assert cube.albedo == (0.2, 0.4, 0.6) and len(cube.faces) == 12
    np.testing.assert_allclose(cube.vertices.min(0), [4, 0, -4])
    np.testing.assert_allclose(cube.vertices.max(0), [6, 2, -2])
    # farthest AABB corner from the camera (0, 2, 10): (+-50, -0.1, -50)
    assert s.max_depth == pytest.approx(np.linalg.norm([50, 2.1, 60]), rel=1e-5)

    L = s.lights
    assert L.dtype == LIGHT_DTYPE and len(L) == 5
    exp = np.zeros(5, LIGHT_DTYPE)
    exp["type"] = [0, 1, 0, 1, 0]
    exp["position"][:2] = [[0, 1, 0], [2, 4, 0]]
    exp["position"][2:] = a["position"]
    exp["radius"] = [3, 10, 2.5, 2.5, 2.5]
    exp["color"][:2] = [[1, 0.9, 0.8], [1, 1, 1]]
    exp["color"][2:] = 0.5
    exp["intensity"] = [5, 20, 4, 4, 4]
    exp["direction"] = [[0, -1, 0], [0, -1, 0], [0, 0, -3], [0, 0, -1], [0, 0, -3]]  # spots normalised
    exp["cos_inner"] = [1, math.cos(math.radians(20)), 0.95, 0.95, 0.95]
    exp["cos_outer"] = [1, math.cos(math.radians(30)), 0.9, 0.9, 0.9]
    for k in LIGHT_DTYPE.names:
        np.testing.assert_array_equal(L[k], exp[k], err_msg=k)
    assert s.light_types() == ["point", "spot"]

    # --lights N keeps the first N (JSON first, then npz); too many is an error
    s3 = load_scene(str(path), lights=3)
    np.testing.assert_array_equal(s3.lights, L[:3])
    with pytest.raises(SceneError, match=r"lights: .*\(got 6\)"):
        load_scene(str(path), lights=6)


def test_minimal_scene_defaults(tmp_path):
    d = {"resolution": [4, 4], "camera": {"position": [0, 0, 0], "target": [0, 0, -1]}, "lights": []}
    s = scene_from_dict(d, tmp_path, "min.json")
    assert s.meshes == [] and len(s.lights) == 0 and s.lights.dtype == LIGHT_DTYPE
    assert s.camera.near == 0.1 and s.camera.far == 1000.0 and s.camera.fov_y_deg == 60.0
    assert s.max_depth == 1000.0
