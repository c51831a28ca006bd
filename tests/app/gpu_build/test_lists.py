"""clustered's --build gpu (app/gpu_build/lists.py): every buffer the GPU builds equals the
CPU build's bit for bit (the visible lights in depth order, their records, rectangles and
depth ranges, the ranges and entries), and the frame is exact against brute, with every
light shape, ties in depth, lights behind the eye and lights off screen."""
from __future__ import annotations

import numpy as np
import pytest

from app.errors import UserError
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import assert_exact, make_scene, options, random_shapes

CLUSTERED = REGISTRY["clustered"]


def _lights(seed: int, n: int):
    rng = np.random.default_rng(seed)
    lights = random_shapes(rng, n, (-20, -2, -40), (20, 9, 12))
    lights["position"][: n // 8] = lights["position"][n // 8: 2 * (n // 8)]   # depth ties
    return lights


def _both(lights, size=(80, 48), **opts):
    with Renderer(make_scene(lights, size=size)) as r:
        cpu = r.render(CLUSTERED, 0, options("clustered", **opts))
        gpu = r.render(CLUSTERED, 0, options("clustered", build=1, **opts))
        ref = r.render(REGISTRY["brute"], 0)
    return cpu, gpu, ref


@pytest.mark.parametrize("seed,n,tile,slices", [(3, 700, 16, 16), (5, 90, 33, 5)])
def test_gpu_build_gives_the_cpu_builds_buffers_bit_for_bit(gl, seed, n, tile, slices):
    cpu, gpu, ref = _both(_lights(seed, n), tile=tile, slices=slices)
    a, b = cpu.build, gpu.build
    assert 0 < len(b.lights) < n                  # some lights culled, some kept
    assert np.array_equal(a.lights.ids, b.lights.ids)
    assert a.lights.gpu.tobytes() == b.lights.gpu.tobytes()
    for name in ("ranges", "entries"):
        assert a.buffers[name].tobytes() == b.buffers[name].tobytes(), name
    assert b.buffers["entries"].size > len(b.lights)       # lights in several cells
    assert gpu.meta["options"]["build"] == 1 and gpu.meta["stats"]["build"] == "gpu"
    assert {"build_cull", "build_sort", "build_bin"} <= set(gpu.meta["gpu_ms"])
    assert_exact({"brute": ref, "clustered": gpu, "cpu": cpu})
    assert (gpu.contrib_count > 0).mean() > 0.2           # lit pixels: the check proves something


def test_gpu_build_refuses_what_it_does_not_build(gl):
    with pytest.raises(UserError, match="--build gpu with --duplicated"):
        CLUSTERED.Options.make({"build": "gpu", "duplicated": True})
