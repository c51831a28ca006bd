"""The pack on the GPU (app/gpu_build/build_pack.comp, build_light.glsl, build_bounds.glsl): every array
of the packed lights (ids, types, float64 spheres and rectangles, GPU rows, float32 bounds and
depth ranges) equals cpu_prep.lights.pack's bit for bit, for many lights of every shape around
the eye, those that cross the near plane (listing 1's general projection), wide and narrow
spot cones, capsules of no length, flat boxes, on odd screens and lenses."""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline.renderer import Renderer
from scenes.model import Camera, LIGHT_BOX, LIGHT_CAPSULE, LIGHT_SPOT
from tests.app.gpu_build.helpers import assert_same_build, hard_lights, render_both
from tests.helpers import make_scene


@pytest.mark.parametrize("seed,size,camera", [
    (11, (17, 13), Camera((0.0, 3.0, 10.0), (0.0, 1.0, -20.0), near=0.1, far=200.0)),
    (12, (31, 9), Camera((2.0, 1.0, -3.0), (-5.0, 4.0, 2.0), fov_y_deg=100.0, near=0.5, far=60.0)),
])
def test_gpu_pack_gives_the_cpu_packs_lights_bit_for_bit(gl, seed, size, camera):
    lights = hard_lights(seed, 3000)
    with Renderer(make_scene(lights, size=size, camera=camera)) as r:
        cpu, gpu = render_both(r, "clustered", {"tile": 8, "slices": 4})
    assert_same_build(cpu, gpu, "clustered")
    pl = cpu.build.lights
    near = -camera.near
    crossing = pl.center[:, 2] + pl.bound_radius >= near        # project_axis_general
    t = pl.type
    spot_cos = pl.gpu["dir_cos_outer"][:, 3]
    caps = pl.gpu["extent_length"][:, 3]
    assert crossing.sum() >= 20 and (~crossing).sum() >= 100
    assert ((t == LIGHT_SPOT) & (spot_cos >= 0.2)).sum() >= 50 and ((t == LIGHT_SPOT) & (spot_cos < 0.2)).sum() >= 5
    assert ((t == LIGHT_CAPSULE) & (caps == 0)).sum() >= 20 and ((t == LIGHT_CAPSULE) & (caps > 0)).sum() >= 50
    assert (t == LIGHT_BOX).sum() >= 100
    w = size[0]
    assert ((pl.rect[:, 0] < 0) & (pl.rect[:, 1] > w)).any()       # rectangles past the screen
