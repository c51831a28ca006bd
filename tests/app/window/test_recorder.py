"""The window's camera path (app.window.recorder): played, taken over by the fly camera,
recorded and saved as a camera path file.  No GL."""
from __future__ import annotations

from types import SimpleNamespace

from scenes import camera_path
from app.window.camera import FlyCamera
from app.window.recorder import PathRecorder
from scenes.model import Camera

CAM = Camera((0.0, 5.0, 30.0), (0.0, 5.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.5, 3000.0)


def scene():
    moved = lambda k, n: Camera((float(k), 5.0, 30.0), (float(k), 5.0, -1.0), (0.0, 1.0, 0.0), 60.0, 0.5, 3000.0)
    return SimpleNamespace(name="city", camera=CAM, camera_at=moved)


def args(tmp_path, **kw):
    return SimpleNamespace(**{"replay": None, "path": False, "record": None, "path_frames": 600,
                              "shot_dir": str(tmp_path), **kw})


def test_play_stop_and_the_fly_camera_takes_over(tmp_path):
    said = []
    r = PathRecorder(scene(), args(tmp_path), said.append)
    fly = FlyCamera(CAM)
    assert not r.playing and r.camera(fly) is CAM
    r.toggle_play(fly)
    r.advance(), r.advance()
    assert r.playing and r.frame == 2 and r.camera(fly).position[0] == 2.0
    r.stop_for(fly)                                  # the user takes the camera where it is
    assert not r.playing and fly.camera().position[0] == 2.0
    r.reset(fly)
    assert r.frame == 0 and fly.camera().position == CAM.position
    assert r.lines()[:2] == ["path: the scene's path (600 frames)", "stopped"]


def test_record_and_save(tmp_path):
    said = []
    out = tmp_path / "fly.json"
    r = PathRecorder(scene(), args(tmp_path, record=str(out)), said.append)
    r.toggle_record((160, 90))
    for k in range(3):
        r.add(scene().camera_at(k, 600))
    assert r.status() == ["REC 3 keys"]
    r.toggle_record((160, 90))                       # stop: saved
    assert r.recording is None and r.saved == [str(out)] and "3 keys" in said[-1]
    back = camera_path.load(out)
    assert len(back) == 3 and back.size == (160, 90) and back.keys[2].position[0] == 2.0
    replay = PathRecorder(scene(), args(tmp_path, replay=str(out)), said.append)
    assert replay.playing and replay.status() == ["replay 1/3"]
