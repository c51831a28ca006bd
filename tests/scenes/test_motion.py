"""Moving lights (scenes.motion): positions a pure, vectorised function of (scene, frame,
frames) that bounce inside their box; the scene file's `motion` and its bad inputs; every
technique exact against brute on moving frames; capture's --motion."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from scenes import SceneError, load_scene, motion as motion_mod, scene_from_dict
from scenes.motion import FPS, Motion, bounce, builtin_motion, lights_at, with_motion
from tests.helpers import assert_exact, make_scene, random_lights

ROOT = Path(__file__).resolve().parents[2]


def test_bounce_reflects_at_the_faces_and_starts_where_the_light_is():
    p0 = np.array([[1.0, 0.0, 0.0]])
    v = np.array([[2.0, 0.0, 0.0]])
    lo, hi = (0.0, 0.0, 0.0), (4.0, 0.0, 1.0)         # y of zero extent: stays put
    at = lambda t: bounce(p0, v, lo, hi, t)[0]
    assert np.allclose(at(0.0), [1, 0, 0])
    assert np.allclose(at(1.0), [3, 0, 0])
    assert np.allclose(at(2.0), [3, 0, 0])            # 5 m travelled: 1 m back off x = 4
    assert np.allclose(at(3.5), [0, 0, 0])            # at the far face
    assert np.allclose(at(4.0), [1, 0, 0])            # a whole period (8 m)


def test_lights_at_is_pure_vectorised_and_stays_in_its_box(monkeypatch):
    scene = load_scene("arena", lights=65536, seed=4)
    assert scene.motion is None and scene.lights_at(7, 64) is scene.lights
    with_motion(scene, "bounce")
    m = scene.motion
    assert np.array_equal(scene.lights_at(0, 64), scene.lights)
    calls = []                   # vectorised: one bounce() over every light, no per-light loop
    monkeypatch.setattr(motion_mod, "bounce", lambda p0, *a: calls.append(p0.shape) or bounce(p0, *a))
    a = scene.lights_at(9, 64)
    assert calls == [(65536, 3)], calls
    monkeypatch.undo()
    assert np.array_equal(a, scene.lights_at(9, 64)) and np.array_equal(a, scene.lights_at(9 + 64, 64))
    moved = np.linalg.norm(a["position"] - scene.lights["position"], axis=1)
    assert np.allclose(moved.max(), m.speed * 9 / FPS, rtol=1e-3)   # no light bounced yet this far
    assert (a["position"] >= np.float32(m.lo)).all() and (a["position"] <= np.float32(m.hi)).all()
    late = scene.lights_at(10_000, 20_000)                          # many bounces
    assert (late["position"] >= np.float32(m.lo)).all() and (late["position"] <= np.float32(m.hi)).all()
    keep = [n for n in a.dtype.names if n != "position"]
    assert all(np.array_equal(a[k], scene.lights[k]) for k in keep)
    assert with_motion(scene, "off").motion is None


SCENE = {"resolution": [64, 36], "camera": {"position": [0, 2, 10], "target": [0, 1, 0]},
         "geometry": [{"box": {"min": [-10, 0, -10], "max": [10, 6, 10]}}],
         "lights": [{"type": "point", "position": [0, 1, 0], "radius": 3, "color": [1, 1, 1],
                     "intensity": 5}]}


def _scene(**motion):
    return scene_from_dict(dict(SCENE, motion=motion), source_name="m.json")


def test_a_scene_file_moves_its_lights():
    s = _scene(kind="bounce", speed=3, seed=2)
    assert s.motion == Motion("bounce", 3.0, 2, (-10.0, 0.0, -10.0), (10.0, 6.0, 10.0))
    assert not np.array_equal(s.lights_at(4, 64)["position"], s.lights["position"])
    b = _scene(kind="bounce", speed=3, bounds={"min": [-5, 0, -5], "max": [5, 2, 5]})
    assert b.motion.lo == (-5.0, 0.0, -5.0) and b.motion.seed == 0
    assert _scene(kind="bounce", speed=0).lights_at(9, 64) is not None


@pytest.mark.parametrize("motion, field", [
    (dict(kind="wobble", speed=1), "motion.kind: unknown motion"),
    (dict(speed=1), "motion.kind: missing required key"),
    (dict(kind="bounce", speed=-1), "motion.speed: must be a finite number in [0, 10000]"),
    (dict(kind="bounce", speed=float("nan")), "motion.speed"),
    (dict(kind="bounce", speed=1, seed=-3), "motion.seed"),
    (dict(kind="bounce", speed=1, sped=2), "motion: unknown key 'sped' (did you mean 'speed'?)"),
    (dict(kind="bounce", speed=1, bounds={"min": [-20, 0, -5], "max": [5, 2, 5]}),
     "motion.bounds: the motion leaves the scene's bounds"),
    (dict(kind="bounce", speed=1, bounds={"min": [2, 0, -5], "max": [5, 2, 5]}),
     "motion: light 0 starts outside the motion's bounds"),
    (dict(kind="bounce", speed=1, bounds={"min": [5, 0, -5], "max": [2, 2, 5]}),
     "motion.bounds.min: must be <= bounds.max"),
])
def test_bad_motions_are_one_line(motion, field):
    with pytest.raises(SceneError) as e:
        _scene(**motion)
    msg = str(e.value)
    assert msg.startswith("m.json: ") and field in msg and "\n" not in msg, msg


def test_a_bad_motion_file_exits_2_in_one_line(tmp_path):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(dict(SCENE, motion={"kind": "bounce", "speed": 1,
                                                "bounds": {"min": [-99, 0, -9], "max": [9, 5, 9]}})))
    p = subprocess.run([sys.executable, "-m", "app.capture", "--scene", str(f), "--size", "16x9"],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "motion.bounds: the motion leaves the scene's bounds" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_every_technique_is_exact_on_moving_frames(gl):
    from app.pipeline.renderer import Renderer
    from app.techniques import REGISTRY
    rng = np.random.default_rng(5)
    scene = make_scene(random_lights(rng, 300, (-20, 0, -40), (20, 8, 5), radius=(0.5, 6.0)),
                       size=(64, 36))
    scene.motion = Motion("bounce", 12.0, 3, (-20.0, 0.0, -40.0), (20.0, 8.0, 5.0))
    with Renderer(scene) as r:
        hashes = []
        for frame in (3, 11):
            res = {n: r.render(t, frame, frames=32) for n, t in REGISTRY.items()}
            assert_exact(res, f"moving frame {frame}")
            hashes.append(res["brute"].contrib_hash)
        assert (hashes[0] != hashes[1]).any(), "the lights did not move: test is void"



def test_capture_renders_and_checks_the_lights_of_its_frame(gl, tmp_path):
    """--motion bounce --frame K --frames F: the dump is frame K's, equal at every pixel to
    brute rendered here on scene.lights_at(K, F) (points, spots, capsules and boxes: the
    corridor), not to the scene's own lights; --check holds it exact on a moving frame; the
    meta says the motion and the frame.  The README's `--build gpu --check`, run as written."""
    from app.dump import read_dump
    from app.pipeline.renderer import Renderer
    from app.techniques import REGISTRY
    k, frames, size = 40, 600, (48, 27)
    dump = tmp_path / "f.npz"
    p = subprocess.run([sys.executable, "-m", "app.capture", "--scene", "corridor", "--lights", "256",
                        "--seed", "2", "--size", "x".join(map(str, size)), "--motion", "bounce",
                        "--frame", str(k), "--frames", str(frames), "--technique", "hybrid",
                        "--build", "gpu", "--check", str(tmp_path / "chk"), "--dump", str(dump)],
                       cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and "exact" in p.stderr, p.stderr
    d = read_dump(dump)
    assert d["meta"]["motion"]["kind"] == "bounce" and d["meta"]["motion"]["frame"] == k
    assert d["meta"]["options"]["build"] == 1
    scene = with_motion(load_scene("corridor", lights=256, seed=2), "bounce")
    scene.resolution = size
    brute = REGISTRY["brute"]
    with Renderer(scene) as r:
        want = r.render(brute, k, frames=frames, lights=scene.lights_at(k, frames))
        still = r.render(brute, k, frames=frames, lights=scene.lights)
    assert len(set(want.build.lights.type.tolist())) == 4        # every shape in view
    assert np.array_equal(d["contrib_count"], want.contrib_count)
    assert np.array_equal(d["contrib_hash"], want.contrib_hash)
    assert (still.contrib_hash != want.contrib_hash).any(), "the lights did not move"
