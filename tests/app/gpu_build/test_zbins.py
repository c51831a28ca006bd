"""zbin's --build gpu (app/gpu_build/zbins.py): the Z-bin LUT, the tile bit arrays, the light
records and depth ranges the GPU builds equal the CPU build's bit for bit, its stats too, and
the frame is exact against brute with lit pixels: every variant, bins not a power of two, a
memory budget that doubles the tile, and past 65,536 visible lights (the wide LUT)."""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.app.gpu_build.helpers import assert_same_build, hard_lights, render_both
from tests.helpers import assert_exact, make_scene, options

ZBIN = REGISTRY["zbin"]

@pytest.mark.parametrize("seed,n,opts", [
    (3, 700, {"zbin_variant": 3, "zbins": 37}),
    (4, 2000, {"zbin_variant": 1, "bit_budget_mib": 1 / 64, "tile_depth": False}),
    (5, 300, {"zbin_variant": 0, "feature_variants": True}),
])
def test_gpu_build_gives_the_cpu_builds_buffers_bit_for_bit(gl, seed, n, opts):
    with Renderer(make_scene(hard_lights(seed, n), size=(96, 64))) as r:
        cpu, gpu = render_both(r, "zbin", opts)
        ref = r.render(REGISTRY["brute"], 0)
    assert 0 < len(gpu.build.lights) < n                  # some lights culled, some kept
    assert_same_build(cpu, gpu, "zbin")
    assert ("zbins" in gpu.build.buffers) == bool(opts["zbin_variant"] & 1)
    assert {"build_cull", "build_sort", "build_bin"} <= set(gpu.meta["gpu_ms"])
    assert_exact({"brute": ref, "zbin": gpu, "cpu": cpu})
    assert (gpu.contrib_count > 0).mean() > 0.2           # lit pixels: the check proves something


def test_budget_doubles_the_tile_on_the_gpu_as_on_the_cpu(gl):
    with Renderer(make_scene(hard_lights(4, 2000), size=(96, 64))) as r:
        got = r.render(ZBIN, 0, options("zbin", build=1, bit_budget_mib=1 / 64))
    assert got.meta["stats"]["bit_tile_used"] > 8


def test_past_65536_lights_the_gpu_builds_the_wide_lut(gl):
    """70,000 visible lights, the lit ones sorted past id 65,535 (test_loop_budget's case):
    the GPU's 32-bit LUT and bits are the CPU's, and the frame is exact."""
    from tests.app.techniques.hard_frames import budget_frame, budget_lights
    with budget_frame() as f:
        L, _ = budget_lights(f, np.random.default_rng(65_537))
        cpu, gpu = render_both(f.renderer, "zbin", {"zbin_variant": 3}, lights=L)
        brute = f.render(L, techniques=["brute"])["brute"]
    assert gpu.meta["stats"]["zbin_id_bits"] == 32 and gpu.build.buffers["zbins"].shape == (8096, 2)
    assert_same_build(cpu, gpu, "zbin")
    assert (brute.contrib_count > 0).any()
    assert_exact({"brute": brute, "zbin": gpu})
