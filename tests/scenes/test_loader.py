"""JSON scene loading: strict validation (one-line errors naming the field) and a round trip."""
import json
import math

import numpy as np
import pytest
import trimesh

from scenes import LIGHT_DTYPE, SceneError, load_scene
from scenes.model import MIN_ROUGHNESS
from scenes.loader import MAX_LIGHTS, scene_from_dict
from tests.helpers import npz_arrays, write_npz

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


CAPSULE = {"type": "capsule", "position": [0, 1, 0], "direction": [1, 0, 0], "length": 4, "radius": 2,
           "color": [1, 1, 1], "intensity": 3}
BOX = {"type": "box", "position": [0, 2, 0], "direction": [0, -2, 0], "up": [0, 0, 1],
       "extent": [2, 1, 3], "color": [1, 1, 1], "intensity": 3}


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
    ("nan_under_unknown_key", _set(["extra"], [1, NAN]), "top level: unknown key 'extra'"),
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
    ("spot_outer_over_90", _set(["lights", 1, "outer_angle_deg"], 90.5), "lights[1].outer_angle_deg:"),
    ("spot_outer_zero", _set(["lights", 1, "outer_angle_deg"], 0), "lights[1].outer_angle_deg:"),
    ("spot_inner_negative", _set(["lights", 1, "inner_angle_deg"], -1), "lights[1].inner_angle_deg:"),
    ("spot_outer_cos_rounds_to_1", lambda d, t: d["lights"][1].update(inner_angle_deg=0,
                                                                      outer_angle_deg=0.01),
     "lights[1].outer_angle_deg: must be wide enough"),
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
    ("npz_bad_type", lambda d, t: with_npz(d, t, type=np.array([0, 7, 0], np.uint8)), "lights_npz.type[1]:"),
    ("npz_type_wraps_in_uint8", lambda d, t: with_npz(d, t, type=np.array([0, 256, 0], np.int64)),
     "lights_npz.type[1]:"),
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
    # unknown keys, at every level: the key and the closest known one
    ("unknown_top_key", _set(["lihgts"], []), "top level: unknown key 'lihgts' (did you mean 'lights'?)"),
    ("unknown_camera_key", _set(["camera", "fov"], 40),
     "camera: unknown key 'fov' (closest known key: 'fov_y_deg'; known keys: position, target"),
    ("unknown_geometry_key", lambda d, t: d["geometry"][0].update(albdo=[1, 0, 0]),
     "geometry[0]: unknown key 'albdo' (did you mean 'albedo'?)"),
    ("unknown_box_key", _set(["geometry", 0, "box", "mx"], [1, 1, 1]),
     "geometry[0].box: unknown key 'mx' (did you mean 'max'?)"),
    ("unknown_light_key", _set(["lights", 0, "colour"], [1, 1, 1]),
     "lights[0]: unknown key 'colour' (did you mean 'color'?)"),
    ("unknown_spot_key", _set(["lights", 1, "inner_angle"], 5),
     "lights[1]: unknown key 'inner_angle' (did you mean 'inner_angle_deg'?)"),
    ("point_light_spot_key", _set(["lights", 0, "direction"], [0, -1, 0]),
     "lights[0]: key 'direction' does not apply to a point light (only to spot, capsule and box lights)"),
    ("box_light_radius", lambda d, t: d["lights"].append(
        {"type": "box", "position": [0, 1, 0], "direction": [0, -1, 0], "up": [0, 0, 1],
         "extent": [1, 1, 1], "radius": 3}),
     "lights[2]: key 'radius' does not apply to a box light (only to point, spot and capsule lights)"),
    ("box_entry_mesh_key", _set(["geometry", 0, "transform"], np.eye(4).tolist()),
     "geometry[0]: key 'transform' does not apply to a box entry (only to mesh entries)"),
    ("unknown_npz_array", lambda d, t: with_npz(d, t, radii=np.ones(3, np.float32)),
     "lights_npz: unknown array 'radii' in 'lights.npz' (did you mean 'radius'?)"),
    ("unknown_key_before_missing_type", _set(["lights", 0, "typ"], "point"),
     "lights[0]: unknown key 'typ' (did you mean 'type'?)"),
    ("roughness_out_of_range", _set(["geometry", 0, "roughness"], 1.5), "geometry[0].roughness:"),
    # capsule and box lights
    ("capsule_length_negative", lambda d, t: d["lights"].append(dict(CAPSULE, length=-1)), "lights[2].length:"),
    ("capsule_direction_zero", lambda d, t: d["lights"].append(dict(CAPSULE, direction=[0, 0, 0])),
     "lights[2].direction:"),
    ("box_extent_zero", lambda d, t: d["lights"].append(dict(BOX, extent=[1, 0, 1])), "lights[2].extent[1]:"),
    ("box_extent_two", lambda d, t: d["lights"].append(dict(BOX, extent=[1, 1])), "lights[2].extent:"),
    ("box_up_parallel", lambda d, t: d["lights"].append(dict(BOX, up=[0, 3, 0])), "lights[2].up:"),
    ("box_up_missing", lambda d, t: d["lights"].append({k: v for k, v in BOX.items() if k != "up"}),
     "lights[2].up: missing"),
    ("npz_box_without_extent", lambda d, t: with_npz(d, t, type=np.array([0, 3, 0], np.uint8),
                                                     up=np.tile([0.0, 1.0, 0.0], (3, 1))),
     "lights_npz.extent: missing array"),
    ("npz_box_up_parallel", lambda d, t: with_npz(d, t, type=np.array([0, 3, 0], np.uint8),
                                                  up=np.tile([0.0, 0.0, 2.0], (3, 1)),
                                                  extent=np.ones((3, 3))),
     "lights_npz.up[1]:"),
    ("npz_capsule_length_negative", lambda d, t: with_npz(d, t, type=np.array([0, 2, 0], np.uint8),
                                                          length=np.array([0, -1.0, 0])),
     "lights_npz.length[1]:"),
    # float32 boundaries: the value as stored decides
    ("radius_zero_in_float32", _set(["lights", 0, "radius"], 1e-46), "lights[0].radius:"),
    ("radius_over_max_in_float32", _set(["lights", 0, "radius"], 1e7 + 1), "lights[0].radius:"),
    ("intensity_inf_in_float32", _set(["lights", 0, "intensity"], 3.4028236e38), "lights[0].intensity:"),
    ("position_inf_in_float32", _set(["lights", 0, "position"], [0, -3.4028236e38, 0]),
     "lights[0].position[1]:"),
    ("npz_radius_zero_in_float32", lambda d, t: with_npz(d, t, radius=np.array([1, 1e-46, 1])),
     "lights_npz.radius[1]:"),
    ("npz_cos_outer_one_in_float32", lambda d, t: with_npz(d, t, cos_inner=np.ones(3),
                                                           cos_outer=np.full(3, 0.99999999)),
     "lights_npz.cos_outer[1]:"),
    ("npz_position_inf_in_float32", lambda d, t: with_npz(d, t, position=np.full((3, 3), 3.4028236e38)),
     "lights_npz.position[0]:"),
    ("npz_cos_inner_over_one", lambda d, t: with_npz(d, t, cos_inner=np.full(3, 1.0000001, np.float32)),
     "lights_npz.cos_inner[1]:"),
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
    a = npz_arrays()
    d["lights_npz"] = write_npz(tmp_path, a, "sub/../l.npz")
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(d))

    s = load_scene(str(path), seed=0)          # the default seed may be passed through
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
    exp["up"][:2] = (0, 0, -1)                      # make_lights' default (JSON lights)
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


# ------------------------------------------------------------------ spot angles, float32, shapes
def _load_lights(d, tmp_path=None):
    return scene_from_dict(d, tmp_path, "mem").lights


def test_spot_angles_follow_gltf():
    """0 <= inner <= outer, 0 < outer <= 90: inner 0 (glTF's default) and outer 90 are valid;
    a 90-degree cone stores cos_outer exactly 0, inner 0 stores cos_inner exactly 1."""
    d = good_dict()
    spot = d["lights"][1]
    cos32 = lambda deg: {0: 1.0, 90: 0.0}.get(deg, np.float32(math.cos(math.radians(deg))))
    for inner, outer in ((0, 90), (0, 30), (90, 90), (30, 30), (20, 89.999), (0, 0.02)):
        spot.update(inner_angle_deg=inner, outer_angle_deg=outer)
        L = _load_lights(d)[1]
        assert L["cos_inner"] == cos32(inner) and L["cos_outer"] == cos32(outer), (inner, outer)
        assert 0 <= L["cos_outer"] < 1 and L["cos_inner"] >= L["cos_outer"]


def test_spot_outer_angle_float32_boundary():
    """The narrowest outer angle whose float32 cosine is still below 1 passes; one a hair
    narrower, whose cosine rounds to 1 (a cone holding nothing), is refused."""
    lo, hi = 1e-4, 1.0                       # degrees: cos rounds to 1 at lo, not at hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if np.float32(math.cos(math.radians(mid))) < 1:
            hi = mid
        else:
            lo = mid
    d = good_dict()
    d["lights"][1].update(inner_angle_deg=0, outer_angle_deg=hi)
    assert _load_lights(d)[1]["cos_outer"] == np.float32(1) - np.float32(2 ** -24)
    d["lights"][1]["outer_angle_deg"] = lo
    with pytest.raises(SceneError, match=r"^mem: lights\[1\]\.outer_angle_deg: must be wide enough"):
        _load_lights(d)


@pytest.mark.parametrize("key, value, stored", [
    ("radius", 1.4e-45, np.float32(1.4e-45)),          # the smallest float32 subnormal: > 0
    ("radius", 1e7 + 0.4, np.float32(1e7)),            # rounds onto the limit: valid as stored
    ("intensity", 3.4028235e38, np.float32(3.4028235e38)),   # float32 max
    ("intensity", 0.0, np.float32(0)),
])
def test_float32_boundary_values_accepted(key, value, stored):
    d = good_dict()
    d["lights"][0][key] = value
    assert _load_lights(d)[0][key] == stored


def test_npz_float32_boundary_values(tmp_path):
    """cos_outer 0.99999994 (the float32 below 1) is a valid narrow cone; 0.99999999 (float64)
    stores 1.0 and is refused; a float64 radius of 1e-46 stores 0 and is refused."""
    d = good_dict()
    a = npz_arrays()
    a["cos_inner"] = np.ones(3)
    a["cos_outer"] = np.full(3, np.float32(1) - np.float32(2 ** -24))
    d["lights_npz"] = write_npz(tmp_path, a)
    L = _load_lights(d, tmp_path)
    assert L["cos_outer"][3] == np.float32(0.99999994) and L["cos_inner"][3] == 1
    a["cos_outer"] = np.full(3, 0.99999999)
    write_npz(tmp_path, a)
    with pytest.raises(SceneError, match=r"lights_npz\.cos_outer\[1\]: .*1\.0 in float32"):
        _load_lights(d, tmp_path)
    a = npz_arrays()
    a["radius"] = np.array([1.0, 1e-46, 1.0])
    write_npz(tmp_path, a)
    with pytest.raises(SceneError, match=r"lights_npz\.radius\[1\]: .*0\.0 in float32"):
        _load_lights(d, tmp_path)


def test_json_float32_message_shows_the_stored_value():
    d = good_dict()
    d["lights"][0]["radius"] = 1e-46
    with pytest.raises(SceneError, match=r"^mem: lights\[0\]\.radius: .*\(got 1e-46, 0\.0 in float32\)$"):
        _load_lights(d)


def test_capsule_and_box_lights(tmp_path):
    d = good_dict()
    d["lights"] += [CAPSULE, BOX]
    a = npz_arrays()
    a["type"] = np.array([2, 3, 0], np.uint8)
    a["length"] = np.array([5.0, 0.0, 0.0], np.float32)
    a["up"] = np.tile(np.float32([0, 1, 0]), (3, 1))
    a["extent"] = np.tile(np.float32([1, 2, 2]), (3, 1))
    d["lights_npz"] = write_npz(tmp_path, a)
    L = _load_lights(d, tmp_path)
    assert L["type"].tolist() == [0, 1, 2, 3, 2, 3, 0]
    cap, box, ncap, nbox = L[2], L[3], L[4], L[5]
    assert cap["length"] == 4 and cap["radius"] == 2 and cap["direction"].tolist() == [1, 0, 0]
    assert box["direction"].tolist() == [0, -1, 0] and box["up"].tolist() == [0, 0, 1]
    assert box["extent"].tolist() == [2, 1, 3]
    assert box["radius"] == np.float32(math.sqrt(14))         # the box's bounding sphere
    assert ncap["length"] == 5 and ncap["radius"] == 2.5
    np.testing.assert_allclose(ncap["direction"], [0, 0, -1])
    assert nbox["extent"].tolist() == [1, 2, 2] and nbox["radius"] == 3
    assert nbox["up"].tolist() == [0, 1, 0]


def test_file_refuses_the_builtin_draw_arguments(tmp_path):
    """A scene file places its own lights: a distribution is an error, a seed other than the
    default 0 too; 0 (or None) passes, so callers may pass their default seed through."""
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(good_dict()))
    for kwargs, field in ((dict(distribution="uniform"), "distribution"), (dict(seed=3), "seed"),
                          (dict(seed=True), "seed"), (dict(seed=0, distribution="geometry"), "distribution")):
        with pytest.raises(SceneError) as ei:
            load_scene(str(path), **kwargs)
        msg = str(ei.value)
        assert "\n" not in msg and msg.startswith(f"{path}: {field}: applies to builtin scenes only"), msg
    assert len(load_scene(str(path), seed=0).lights) == 2
    assert len(load_scene(str(path), seed=None).lights) == 2


def test_unknown_key_messages_are_exact(tmp_path):
    """The message of the issue, word for word."""
    d = good_dict()
    d["geometry"][0]["albdo"] = d["geometry"][0].pop("albedo")
    with pytest.raises(SceneError) as ei:
        scene_from_dict(d, tmp_path, "scene.json")
    assert str(ei.value) == "scene.json: geometry[0]: unknown key 'albdo' (did you mean 'albedo'?)"


def test_material_keys_of_the_contract(tmp_path):
    d = good_dict()
    d["geometry"][0].update(roughness=0.3, metallic=1.0)
    with_mesh(d, tmp_path, roughness=0.5, albedo=[0.1, 0.2, 0.3])
    box, mesh = scene_from_dict(d, tmp_path, "mem").meshes
    assert (box.albedo, box.roughness, box.metallic) == ((0.8, 0.8, 0.8), 0.3, 1.0)
    assert (mesh.albedo, mesh.roughness, mesh.metallic) == ((0.1, 0.2, 0.3), 0.5, 0.0)
    d = good_dict()
    assert scene_from_dict(d, None, "mem").meshes[0].roughness == 0.0     # matte by default
    d["geometry"][0]["roughness"] = 1e-3             # GGX's float32 peak would be infinite
    assert scene_from_dict(d, None, "mem").meshes[0].roughness == MIN_ROUGHNESS
    del d["geometry"][0]["roughness"]
    d["geometry"][0]["metallic"] = -0.5
    with pytest.raises(SceneError, match=r"^mem: geometry\[0\]\.metallic: "):
        scene_from_dict(d, None, "mem")
