"""zbin's --build gpu (app/gpu_build/zbins.py): the Z-bin LUT, the tile bit arrays, the light
records and depth ranges the GPU builds equal the CPU build's bit for bit, its stats too, and
the frame is exact against brute with lit pixels: every variant, bins not a power of two, a
memory budget that doubles the tile, and past 65,536 visible lights (the wide LUT)."""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline.passes import FrameInput
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.helpers import assert_exact, make_scene, options, random_shapes

ZBIN = REGISTRY["zbin"]
BUFFERS = ("lights", "light_depth", "tile_bits", "zbins")


def _lights(seed: int, n: int):
    rng = np.random.default_rng(seed)
    lights = random_shapes(rng, n, (-20, -2, -40), (20, 9, 12))
    lights["position"][: n // 8] = lights["position"][n // 8: 2 * (n // 8)]   # depth ties
    return lights


def assert_same_build(cpu, gpu, names=BUFFERS) -> None:
    """Every buffer the CPU build made (of `names`) equals the GPU's bit for bit, and the
    stats agree but for the build's name."""
    a, b = cpu.build, gpu.build
    assert np.array_equal(a.lights.ids, b.lights.ids)
    for name in names:
        if name in a.buffers:
            assert a.buffers[name].tobytes() == b.buffers[name].tobytes(), name
            assert a.buffers[name].shape == b.buffers[name].shape, name
    sa, sb = dict(cpu.meta["stats"]), dict(gpu.meta["stats"])
    assert sb.pop("build") == "gpu" and sb == sa
    assert gpu.meta["options"]["build"] == 1


@pytest.mark.parametrize("seed,n,opts", [
    (3, 700, {"zbin_variant": 3, "zbins": 37}),
    (4, 2000, {"zbin_variant": 1, "bit_budget_mib": 1 / 64, "tile_depth": False}),
    (5, 300, {"zbin_variant": 0, "feature_variants": True}),
])
def test_gpu_build_gives_the_cpu_builds_buffers_bit_for_bit(gl, seed, n, opts):
    with Renderer(make_scene(_lights(seed, n), size=(96, 64))) as r:
        cpu = r.render(ZBIN, 0, options("zbin", **opts))
        gpu = r.render(ZBIN, 0, options("zbin", build=1, **opts))
        ref = r.render(REGISTRY["brute"], 0)
    assert 0 < len(gpu.build.lights) < n                  # some lights culled, some kept
    assert_same_build(cpu, gpu)
    assert ("zbins" in gpu.build.buffers) == bool(opts["zbin_variant"] & 1)
    assert {"build_cull", "build_sort", "build_bin"} <= set(gpu.meta["gpu_ms"])
    assert_exact({"brute": ref, "zbin": gpu, "cpu": cpu})
    assert (gpu.contrib_count > 0).mean() > 0.2           # lit pixels: the check proves something


def test_budget_doubles_the_tile_on_the_gpu_as_on_the_cpu(gl):
    with Renderer(make_scene(_lights(4, 2000), size=(96, 64))) as r:
        got = r.render(ZBIN, 0, options("zbin", build=1, bit_budget_mib=1 / 64))
    assert got.meta["stats"]["bit_tile_used"] > 8


def test_past_65536_lights_the_gpu_builds_the_wide_lut(gl):
    """70,000 visible lights, the lit ones sorted past id 65,535 (test_loop_budget's case):
    the GPU's 32-bit LUT and bits are the CPU's, and the frame is exact."""
    from tests.app.techniques.test_loop_budget import budget_frame, budget_lights
    with budget_frame() as f:
        L, _ = budget_lights(f, np.random.default_rng(65_537))
        cpu = f.renderer.render(ZBIN, 0, {"zbin_variant": 3}, lights=L)
        gpu = f.renderer.render(ZBIN, 0, {"zbin_variant": 3, "build": "gpu"}, lights=L)
        brute = f.render(L, techniques=["brute"])["brute"]
    assert gpu.meta["stats"]["zbin_id_bits"] == 32 and gpu.build.buffers["zbins"].shape == (8096, 2)
    assert_same_build(cpu, gpu)
    assert (brute.contrib_count > 0).any()
    assert_exact({"brute": brute, "zbin": gpu})
