"""A scene file's `fog` block (docs/contracts.md "Contract: scene files", Additions): the
medium's fields checked like every other field (one line naming it, exit status 2), its
defaults, and the builtin variant hangar-fog beside the unchanged hangar."""
import subprocess
import sys
from pathlib import Path

import pytest

from scenes import BUILTIN_SCENES, BUILTIN_VARIANTS, Fog, SceneError, load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[2]


def scene(fog) -> dict:
    return {"resolution": [64, 36], "camera": {"position": [0, 2, 10], "target": [0, 2, 0],
                                               "near": 0.5, "far": 300},
            "lights": [{"type": "point", "position": [0, 1, 0], "radius": 3,
                        "color": [1, 1, 1], "intensity": 5}], "fog": fog}


def test_fog_block_and_its_defaults():
    assert scene_from_dict(scene({"density": 0.1})).fog == Fog(0.1, (0.9, 0.9, 0.9), 300.0, 0.0)
    f = scene_from_dict(scene({"density": 0, "albedo": [0.2, 0.5, 1], "far": 50,
                               "anisotropy": -0.7})).fog
    assert f == Fog(0.0, (0.2, 0.5, 1.0), 50.0, -0.7)
    d = scene({})
    del d["fog"]
    assert scene_from_dict(d).fog is None


@pytest.mark.parametrize("fog, field", [
    ({"density": -0.01}, "fog.density"),
    ({"density": 0.1, "albedo": 1.01}, "fog.albedo"),
    ({"density": 0.1, "albedo": [0.5, -0.1, 0.5]}, "fog.albedo"),
    ({"density": 0.1, "albedo": [0.5, 0.5, 1.5]}, r"fog.albedo\[2\]"),
    ({"density": 0.1, "anisotropy": 1.0}, "fog.anisotropy"),
    ({"density": 0.1, "anisotropy": -1.0}, "fog.anisotropy"),
    ({"density": 0.1, "far": 0}, "fog.far"),
    ({"density": 0.1, "far": -5}, "fog.far"),
    ({"density": 0.1, "far": 0.5}, "fog.far"),                 # not beyond camera.near
    ({"density": float("nan")}, "fog.density"),
    ({"albedo": 0.5}, "fog.density"),                          # required
    ({"density": 0.1, "dense": 1}, "did you mean"),
    ([0.1], "fog"),
])
def test_bad_fog_is_one_line_naming_the_field(fog, field):
    with pytest.raises(SceneError, match=field) as e:
        scene_from_dict(scene(fog), source_name="s.json")
    assert "\n" not in str(e.value)


def test_bad_fog_through_capture_exits_2_with_one_line(tmp_path):
    import json
    p = tmp_path / "s.json"
    p.write_text(json.dumps(scene({"density": 0.1, "anisotropy": 1.5})))
    r = subprocess.run([sys.executable, "-m", "app.capture", "--scene", str(p)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "fog.anisotropy" in r.stderr


def test_hangar_fog_is_a_variant_beside_the_unchanged_hangar():
    assert "hangar-fog" in BUILTIN_VARIANTS and "hangar-fog" not in BUILTIN_SCENES
    plain, foggy = load_scene("hangar", 50), load_scene("hangar-fog", 50)
    assert plain.fog is None and foggy.fog is not None and foggy.fog.density > 0
    assert (plain.lights == foggy.lights).all() and plain.camera == foggy.camera
    assert foggy.fog.far <= foggy.camera.far
