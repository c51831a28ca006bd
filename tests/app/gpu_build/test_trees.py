"""tree's and hybrid's --build gpu (app/gpu_build/trees.py): the light records, index lists,
cell ranges and tree nodes (bounds, first light, leaf flag, count, skip count) the GPU builds
equal the CPU build's bit for bit, their stats too, and the frames are exact against brute
with lit pixels: leaves that split a cell's lights unevenly, empty leaves (one light a leaf
of a cell with fewer lights than leaves), listing 2 choosing both ways, the 16-bit leaf
count's split of a list past 65,535 lights."""
from __future__ import annotations

import numpy as np
import pytest

from app.errors import UserError
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from tests.app.gpu_build.helpers import assert_same_build, hard_lights, render_both
from tests.helpers import assert_exact, make_scene


def _both(name, lights, size=(80, 48), **opts):
    with Renderer(make_scene(lights, size=size)) as r:
        cpu, gpu = render_both(r, name, opts)
        ref = r.render(REGISTRY["brute"], 0)
    return cpu, gpu, ref


@pytest.mark.parametrize("name,seed,n,opts", [
    ("tree", 3, 700, {"tile": 16, "lights_per_leaf": 3, "max_leaves": 16}),
    ("tree", 6, 200, {"tile": 33, "lights_per_leaf": 1, "max_leaves": 64}),
    ("hybrid", 3, 700, {"tile": 16, "slices": 8}),
    ("hybrid", 5, 400, {"tile": 24, "slices": 5, "radius_scale": 0.5, "lights_per_leaf": 2}),
])
def test_gpu_build_gives_the_cpu_builds_trees_bit_for_bit(gl, name, seed, n, opts):
    cpu, gpu, ref = _both(name, hard_lights(seed, n), **opts)
    assert_same_build(cpu, gpu, name)
    s = gpu.meta["stats"]
    assert s["trees"] > 0 and s["lists"] > 0 if name == "hybrid" else s["trees"] > 0
    nodes = gpu.build.buffers["nodes"]
    assert (nodes["bits"] >> 17).max() > 1                 # inner nodes with skip counts
    if opts.get("lights_per_leaf") == 1:                   # empty leaves: +inf / -inf bounds
        assert np.isinf(nodes["min_depth"]).any()
    assert {"build_cull", "build_sort", "build_bin", "build_tree"} <= set(gpu.meta["gpu_ms"])
    assert_exact({"brute": ref, name: gpu, "cpu": cpu})
    assert (gpu.contrib_count > 0).mean() > 0.2            # lit pixels: the check proves something


@pytest.mark.parametrize("flag,value", [("sort_buckets", 512), ("tree_build", "topdown"),
                                        ("duplicated", True)])
def test_gpu_build_refuses_what_it_does_not_build(gl, flag, value):
    with pytest.raises(UserError, match=f"--build gpu with --{flag.replace('_', '-')}"):
        REGISTRY["tree"].Options.make({"build": "gpu", flag: value})


def test_a_cell_past_65535_lights_splits_and_listing_2_sums_over_windows(gl):
    """70,000 visible lights in one cell (test_loop_budget's frame): listing 2's sum runs over
    several dispatch windows (carried from one to the next), the list it chooses is stored as
    two leaves (16-bit counts), as is tree's one-leaf tree; both bit for bit, exact, lit."""
    from app.pipeline.passes import FrameInput
    from app.techniques.base import windows
    from tests.app.techniques.hard_frames import budget_frame, budget_lights
    with budget_frame() as f:
        L, _ = budget_lights(f, np.random.default_rng(65_537))
        brute = f.render(L, techniques=["brute"])["brute"]
        got = {}
        for name, opts in (("hybrid", {"slices": 2, "tile": 32, "radius_scale": 1e-3}),
                           ("tree", {"tile": 32, "max_leaves": 1})):
            cpu, got[name] = render_both(f.renderer, name, opts, lights=L)
            assert_same_build(cpu, got[name], name)
        fi = FrameInput(L, f.cam, f.scene.max_depth, loop_budget=f.renderer.limits.loop_budget)
    assert len(windows(fi, got["hybrid"].build.longest_list)) > 1
    assert got["hybrid"].meta["stats"]["lists_stored_as_trees"] == 1
    assert got["tree"].meta["stats"]["nodes"] == 3                  # two leaves and a root
    assert (brute.contrib_count > 0).any()
    assert_exact(dict(got, brute=brute))
