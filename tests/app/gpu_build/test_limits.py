"""The GPU build's limits: a buffer past the driver's storage-block limit (the scene's light
records, the visible lights' rows, the list entries) is refused in one line naming it and
the most it holds, before anything is allocated; a dispatch past the groups a dimension
holds takes the 2D layout (forced here with a small MAX_GROUPS_X), bit for bit the same."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.errors import UserError
from app.gpu_build import steps
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from cpu_prep.layouts import GPU_LIGHT
from scenes.model import LIGHT_DTYPE, make_lights
from tests.app.gpu_build.helpers import assert_same_build, hard_lights, render_both
from tests.helpers import assert_exact, make_scene, options

LIMIT = 44 << 10        # the storage-block limit of these tests' driver (bytes)


def _in_front(n: int, radius: float):
    """n point lights in front of the camera, all visible."""
    rng = np.random.default_rng(n)
    lights = make_lights(n)
    lights["position"] = rng.uniform((-3, 0, -10), (3, 4, -2), (n, 3))
    lights["radius"] = radius
    lights["color"] = 1.0
    lights["intensity"] = 1.0
    return lights


def _refusal(lights, size=(48, 32), **opts) -> str:
    with Renderer(make_scene(lights, size=size)) as r:
        r.limits = dataclasses.replace(r.limits, max_storage_block=LIMIT)
        with pytest.raises(UserError) as exc:
            r.render(REGISTRY["clustered"], 0, options("clustered", build=1, **opts))
    assert "\n" not in str(exc.value)
    return str(exc.value)


@pytest.mark.parametrize("n,radius,opts,what,unit,item", [
    (600, 0.5, {}, "the scene's light records", "scene lights", LIGHT_DTYPE.itemsize),
    (500, 0.5, {}, "the visible lights' rows", "visible lights", GPU_LIGHT.itemsize),
    (100, 40.0, {"tile": 8, "slices": 16}, "the light index list", "list entries", 4),
])
def test_a_buffer_past_the_storage_block_limit_is_refused_naming_the_most_it_takes(gl, n, radius, opts,
                                                                                  what, unit, item):
    lights = _in_front(n, radius)
    with Renderer(make_scene(lights, size=(48, 32))) as r:         # the counts, as the CPU builds them
        stats = r.render(REGISTRY["clustered"], 0, options("clustered", **opts)).meta["stats"]
    count = {"scene lights": n, "visible lights": stats["visible_lights"],
             "list entries": stats["list_entries"]}[unit]
    assert count * item > LIMIT and stats["visible_lights"] == n
    line = _refusal(lights, **opts)
    assert line.startswith(f"--build gpu: {what} of {count:,} {unit} needs ")
    assert line.endswith(f"storage-block limit (at most {LIMIT // item:,} {unit})")


def test_dispatches_past_one_dimension_take_the_2d_layout_bit_for_bit(gl, monkeypatch):
    monkeypatch.setattr(steps, "MAX_GROUPS_X", 3)          # every dispatch of > 3 groups is 2D
    assert steps.groups(20) == (3, 7, 1)
    with Renderer(make_scene(hard_lights(7, 900), size=(48, 32))) as r:
        ref = r.render(REGISTRY["brute"], 0)
        for name, opts in (("hybrid", {"tile": 8, "slices": 8}), ("zbin", {"zbins": 300})):
            cpu, gpu = render_both(r, name, opts)
            assert_same_build(cpu, gpu, name)
            assert_exact({"brute": ref, name: gpu})
