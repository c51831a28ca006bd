"""The benchmark sweep honours a scene file's `motion` (docs/contracts.md) as capture does:
a job's lights are the scene's at the job's frame of the path loop (Scene.lights_at, the
lights capture's --frame K --frames F renders), cutoffs applied to those; --motion
overrides it (off: still; bounce: a builtin moves)."""
import json

import numpy as np

from app.bench.plan import Job
from app.bench.presets import QUICK
from app.bench.sweep import Sweep, sweep_main
from app.techniques import REGISTRY

SCENE = {"resolution": [64, 36], "camera": {"position": [0, 2, 10], "target": [0, 1, 0]},
         "geometry": [{"box": {"min": [-10, 0, -10], "max": [10, 6, 10]}}],
         "lights": [{"type": "point", "position": [x, 1, 0], "radius": 3, "color": [1, 1, 1],
                     "intensity": 5} for x in (-4, 0, 4)],
         "motion": {"kind": "bounce", "speed": 6, "seed": 2}}
P = QUICK.changed(shared=dict(frames=8))


def _job(path, frame, cutoff=0):
    return Job("path", str(path), 3, frame, "brute", REGISTRY["brute"].Options(), cutoff)


def _file(tmp_path):
    path = tmp_path / "moving.json"
    path.write_text(json.dumps(SCENE))
    return path


def test_a_scene_files_motion_moves_the_sweeps_lights(tmp_path):
    path = _file(tmp_path)
    sw = Sweep(P)
    sc = sw.scene(str(path), 3)
    assert sc.motion is not None and sc.motion.speed == 6
    first, later = sw.lights_for(_job(path, 0)), sw.lights_for(_job(path, 5))
    assert np.array_equal(later, sc.lights_at(5, P.shared.frames))          # capture's frame 5 of 8
    assert not np.array_equal(first["position"], later["position"])
    # a cutoff's radii on the moved lights, one light set a frame
    cut0, cut5 = sw.lights_for(_job(path, 0, 16)), sw.lights_for(_job(path, 5, 16))
    assert np.array_equal(cut5["position"], later["position"])
    assert not np.array_equal(cut0["position"], cut5["position"])


def test_motion_overrides_the_files_and_a_builtins(tmp_path):
    path = _file(tmp_path)
    still = Sweep(P, motion="off")
    assert still.scene(str(path), 3).motion is None
    assert np.array_equal(still.lights_for(_job(path, 5)), still.lights_for(_job(path, 0)))
    moving = Sweep(P, motion="bounce")
    sc = moving.scene("arena", 64)
    job = lambda k: Job("path", "arena", 64, k, "brute", REGISTRY["brute"].Options())
    assert sc.motion is not None
    assert not np.array_equal(moving.lights_for(job(0))["position"], moving.lights_for(job(3))["position"])
    assert Sweep(P).scene("arena", 64).motion is None


def test_the_sweep_command_takes_motion(capsys):
    import pytest
    with pytest.raises(SystemExit) as e:
        sweep_main(["--out", "x", "--motion", "sideways"])
    assert e.value.code == 2 and "--motion" in capsys.readouterr().err
