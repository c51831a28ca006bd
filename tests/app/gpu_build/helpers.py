"""What the GPU build's tests share: a frame's lights with the hard cases, both builds of one
frame held apart, and the bit-for-bit comparison of each technique's buffers (BUFFERS) and
stats."""
from __future__ import annotations

import dataclasses

import numpy as np

from tests.helpers import options, random_shapes


def hard_lights(seed: int, n: int):
    """n lights of every shape, some behind the eye and off screen, an eighth of them at
    another eighth's positions (depth ties: the sort's stability)."""
    rng = np.random.default_rng(seed)
    lights = random_shapes(rng, n, (-20, -2, -40), (20, 9, 12))
    lights["position"][: n // 8] = lights["position"][n // 8: 2 * (n // 8)]
    return lights


def frozen(res):
    """res with its build's arrays copied: the renderer's arena reuses them frame after
    frame (both builds pack into it), so a later frame would overwrite what is compared."""
    b = res.build
    b.buffers = {k: np.array(v, copy=True) for k, v in b.buffers.items()}
    b.lights = dataclasses.replace(b.lights, **{
        f.name: np.array(getattr(b.lights, f.name), copy=True) for f in dataclasses.fields(b.lights)})
    return res


# The buffers each technique's shading reads: the CPU build makes these and no other, the
# GPU build these (bit for bit) and its own intermediates (scene_lights, gb_*, light_depth).
# Named here, so that a buffer one build renames or stops making fails instead of dropping
# out of the comparison.
BUFFERS = {
    "clustered": ("lights", "ranges", "entries"),
    "tree": ("lights", "ranges", "entries", "nodes"),
    "hybrid": ("lights", "ranges", "entries", "nodes"),
    "zbin": ("lights", "tile_bits"),
}


def buffers(technique: str, opts: dict) -> tuple[str, ...]:
    """BUFFERS[technique] and those its options add (zbin: the LUT of the masked variants,
    1 and 3; the depth ranges of --tile-depth)."""
    extra = ()
    if technique == "zbin":
        extra = ("zbins",) * (opts["zbin_variant"] & 1) + ("light_depth",) * bool(opts["tile_depth"])
    return BUFFERS[technique] + extra


def render_both(renderer, name: str, opts: dict, frame: int = 0, **kw):
    """(cpu, gpu): one frame of technique `name` built on the CPU, then on the GPU."""
    from app.techniques import REGISTRY
    t = REGISTRY[name]
    cpu = frozen(renderer.render(t, frame, options(name, **opts), **kw))
    gpu = frozen(renderer.render(t, frame, options(name, build=1, **opts), **kw))
    return cpu, gpu


def assert_same_build(cpu, gpu, technique: str) -> None:
    """The packed lights (every array) and every buffer of the technique's buffers(), which
    both builds must have, equal bit for bit, and the stats agree but for the build's name."""
    a, b = cpu.build, gpu.build
    for f in dataclasses.fields(a.lights):        # ids, types, spheres, rectangles, rows, bounds, depths
        x, y = getattr(a.lights, f.name), getattr(b.lights, f.name)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), f.name
    want = buffers(technique, cpu.meta["options"])
    assert sorted(a.buffers) == sorted(want), f"{technique}: the CPU build made {sorted(a.buffers)}"
    for name in want:
        assert name in b.buffers, f"{technique}: {name} missing from the GPU build"
        assert a.buffers[name].dtype == b.buffers[name].dtype, name
        assert a.buffers[name].shape == b.buffers[name].shape, name
        assert a.buffers[name].tobytes() == b.buffers[name].tobytes(), name
    sa, sb = dict(cpu.meta["stats"]), dict(gpu.meta["stats"])
    assert sb.pop("build") == "gpu" and sb == sa
    assert gpu.meta["options"]["build"] == 1
