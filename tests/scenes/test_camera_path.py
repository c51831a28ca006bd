"""Camera path files (scenes.camera_path): round trip, bad files in one line, and the one
camera check they share with the scene loader (scenes.loader.check_camera).  No GL."""
from __future__ import annotations

import json

import pytest

from scenes import SceneError, camera_path, scene_from_dict


def test_camera_path_round_trip_and_bad_files(tmp_path):
    from scenes.model import Camera
    path = camera_path.CameraPath(scene="city", size=(320, 180))
    for k in range(3):
        path.add(Camera((0.0, 5.0, 30.0 - k), (0.0, 5.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.5, 3000.0), k / 30)
    f = path.save(tmp_path / "p.json")
    back = camera_path.load(f)
    assert len(back) == 3 and back.keys == path.keys and back.scene == "city" and back.size == (320, 180)
    assert back.camera(4) == path.keys[1]                          # loops
    good = json.loads(f.read_text())
    cases = [({"keys": []}, "keys: must be a non-empty"),
             ({**good, "keyz": 1}, "unknown field 'keyz'"),
             ({**good, "version": 9}, "version"),
             ({**good, "keys": [{**good["keys"][0], "fov_y_deg": float("nan")}]}, "fov_y_deg"),
             ({**good, "keys": [{**good["keys"][0], "near": 0}]}, "near"),
             ({**good, "keys": [{**good["keys"][0], "target": good["keys"][0]["position"]}]}, r"keys\[0\]\.target: must differ from"),
             ({**good, "keys": [{k: v for k, v in good["keys"][0].items() if k != "up"}]}, r"keys\[0\]\.up: missing required key"),
             ({**good, "keys": good["keys"][::-1]}, "time order")]
    for data, words in cases:
        (tmp_path / "bad.json").write_text(json.dumps(data))
        with pytest.raises(SceneError, match=words) as e:
            camera_path.load(tmp_path / "bad.json")
        assert "\n" not in str(e.value)
    (tmp_path / "bad.json").write_text("{nope")
    with pytest.raises(SceneError, match="not JSON"):
        camera_path.load(tmp_path / "bad.json")


def camera_key(**kw) -> dict:
    key = {"position": [0.0, 5.0, 30.0], "target": [0.0, 5.0, -1.0], "up": [0.0, 1.0, 0.0],
           "fov_y_deg": 60.0, "near": 0.5, "far": 3000.0}
    return {**key, **kw}


def path_takes(key: dict) -> bool:
    try:
        camera_path.from_dict({"keys": [key]})
    except SceneError:
        return False
    return True


def scene_takes(key: dict) -> bool:
    try:
        scene_from_dict({"resolution": [64, 36], "camera": key, "geometry": [], "lights": []})
    except SceneError:
        return False
    return True


@pytest.mark.parametrize("fields", [
    {"fov_y_deg": 179.5}, {"fov_y_deg": 180.0}, {"fov_y_deg": 0.0}, {"fov_y_deg": 1e-3},
    {"near": 0.0}, {"far": 0.4}, {"far": 1e12}, {"up": [0.0, 0.0, -1.0]}, {"up": [0.0, 0.0, 0.0]},
    {"target": [0.0, 5.0, 30.0]}, {"position": [0.0, float("inf"), 0.0]}, {"zoom": 2.0},
])
def test_a_path_key_and_a_scene_camera_pass_the_same_check(fields):
    """One check (scenes.loader.check_camera): a wide 179.5 degree camera a scene may have is
    a camera its recorded path may have too (they drifted: fov < 179 against < 180)."""
    assert path_takes(camera_key()) and scene_takes(camera_key())
    key = camera_key(**fields)
    assert path_takes(key) == scene_takes(key)


def test_a_path_key_names_its_index_and_field():
    with pytest.raises(SceneError, match=r"^camera path: keys\[0\]\.fov_y_deg: must be a finite number in \(0, 180\)"):
        camera_path.from_dict({"keys": [camera_key(fov_y_deg=180.0)]})
    assert camera_path.from_dict({"keys": [camera_key(fov_y_deg=179.5)]}).keys[0].fov_y_deg == 179.5
