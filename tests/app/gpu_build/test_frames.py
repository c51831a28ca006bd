"""A GPU-built frame as the renderer hands it over: its meta's features are those of the
visible lights (a shape only culled lights have compiles nowhere), as the CPU build's, and
with several samples its build is the one whose steps ran (the packed lights, the stats and
the read-back structures), not a later sample's stand-in."""
from __future__ import annotations

import numpy as np

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes.model import LIGHT_BOX, LIGHT_POINT
from tests.app.gpu_build.helpers import assert_same_build, frozen, hard_lights
from tests.helpers import assert_exact, make_scene, options


def _boxes_behind(n: int):
    """Lights in view, of every shape but boxes, and boxes all behind the eye (culled)."""
    lights = hard_lights(21, n)
    boxes = lights["type"] == LIGHT_BOX
    lights["type"][boxes] = LIGHT_POINT
    extra = hard_lights(22, 40)
    extra["type"] = LIGHT_BOX
    extra["extent"] = 0.5
    extra["position"] = (0.0, 3.0, 40.0)                    # behind the camera at z = 10
    return np.concatenate([lights, extra])


def test_gpu_frames_compile_the_visible_shapes_and_keep_the_built_frame(gl):
    lights = _boxes_behind(400)
    with Renderer(make_scene(lights, size=(48, 32))) as r:
        brute = r.render(REGISTRY["brute"], 0)
        assert "box" not in brute.meta["features"]
        for name in ("clustered", "tree", "hybrid", "zbin"):
            t = REGISTRY[name]
            cpu = frozen(r.render(t, 0, options(name)))
            gpu = frozen(r.render(t, 0, options(name, build=1), samples=2))
            assert cpu.meta["features"] == gpu.meta["features"] and "box" not in gpu.meta["features"], name
            assert len(gpu.meta["samples"]) == 2
            assert_same_build(cpu, gpu, name)
            assert_exact({"brute": brute, "cpu": cpu, name: gpu})
            assert (gpu.contrib_count > 0).mean() > 0.2, name
