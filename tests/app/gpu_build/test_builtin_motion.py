"""--build gpu past one still frame of random lights: on a builtin scene of every light shape
(corridor) whose lights move (--motion bounce), a later frame of every technique the GPU
builds equals the CPU build's bit for bit and is exact against brute of that frame."""
from __future__ import annotations

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes import load_scene
from scenes.motion import with_motion
from tests.app.gpu_build.helpers import BUFFERS, assert_same_build, render_both
from tests.helpers import assert_exact, takes

FRAME, FRAMES = 45, 120


def test_a_moving_frame_of_a_builtin_scene_builds_bit_for_bit(gl):
    assert sorted(BUFFERS) == sorted(n for n in REGISTRY if takes(n, "build"))
    scene = load_scene("corridor", lights=600, seed=3)
    scene.resolution = (64, 36)
    with_motion(scene, "bounce")
    with Renderer(scene) as r:
        ref = r.render(REGISTRY["brute"], FRAME, frames=FRAMES)
        still = r.render(REGISTRY["brute"], 0, frames=FRAMES)
        assert (ref.contrib_hash != still.contrib_hash).any(), "the lights did not move"
        assert len(set(ref.build.lights.type.tolist())) == 4          # every shape in view
        for name in BUFFERS:
            cpu, gpu = render_both(r, name, {}, FRAME, frames=FRAMES)
            assert_same_build(cpu, gpu, name)
            assert_exact({"brute": ref, name: gpu}, f"{name}, frame {FRAME}")
    assert (ref.contrib_count > 0).mean() > 0.2
