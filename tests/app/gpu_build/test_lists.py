"""clustered's --build gpu (app/gpu_build/lists.py): every buffer the GPU builds equals the
CPU build's bit for bit (the visible lights in depth order, their records, the ranges and
entries), its stats too, and the frame is exact against brute, with every light shape, ties
in depth, lights behind the eye and lights off screen."""
from __future__ import annotations

import pytest

from app.errors import UserError
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.app.gpu_build.helpers import assert_same_build, hard_lights, render_both
from tests.helpers import assert_exact, make_scene

CLUSTERED = REGISTRY["clustered"]


@pytest.mark.parametrize("seed,n,tile,slices", [(3, 700, 16, 16), (5, 90, 33, 5)])
def test_gpu_build_gives_the_cpu_builds_buffers_bit_for_bit(gl, seed, n, tile, slices):
    with Renderer(make_scene(hard_lights(seed, n), size=(80, 48))) as r:
        cpu, gpu = render_both(r, "clustered", {"tile": tile, "slices": slices})
        ref = r.render(REGISTRY["brute"], 0)
    b = gpu.build
    assert 0 < len(b.lights) < n                  # some lights culled, some kept
    assert_same_build(cpu, gpu, "clustered")
    assert b.buffers["entries"].size > len(b.lights)       # lights in several cells
    assert {"build_cull", "build_sort", "build_bin"} <= set(gpu.meta["gpu_ms"])
    assert_exact({"brute": ref, "clustered": gpu, "cpu": cpu})
    assert (gpu.contrib_count > 0).mean() > 0.2           # lit pixels: the check proves something


def test_gpu_build_refuses_what_it_does_not_build(gl):
    with pytest.raises(UserError, match="--build gpu with --duplicated"):
        CLUSTERED.Options.make({"build": "gpu", "duplicated": True})
