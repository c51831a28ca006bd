"""Technique.refusal: the limit a frame meets, from its counts and options alone, in the line
the build raises, so that the window's probe can leave a refusing technique out unbuilt
(tests/app/window/test_probe.py).  The limits are lowered to the frame's counts here: the
same code paths as a million lights meet, at 600."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

from app.errors import UserError
from app.gpu_build import prepare as gpuprep
from app.pipeline.passes import FrameInput
from app.techniques import REGISTRY
from app.techniques.base import prepare, visible_lights
from cpu_prep import caps, layouts, limits
from cpu_prep.camera import frame_camera
from scenes import load_scene

SIZE = (64, 36)


def city_frame(lights: int = 600, **kw) -> FrameInput:
    scene = load_scene("city", lights=lights)
    return FrameInput(scene.lights, frame_camera(scene.camera, *SIZE), scene.max_depth, **kw)


def refused_build(technique, frame, opts) -> str:
    """The line the build (and the passes it hands over) refuses with."""
    with pytest.raises((UserError, limits.LimitError)) as exc:
        technique.passes(technique.build(frame, opts), opts)
    return str(exc.value)


def test_visible_lights_counts_what_prepare_packs():
    f = city_frame()
    Options = REGISTRY["tiled"].Options
    counts = {}
    for what, opts in (("plain", Options()), ("capped", Options(cap_policy=caps.NAMES.index("urp-16"))),
                       ("stochastic", Options(stochastic=4))):
        counts[what] = visible_lights(f, opts)
        assert counts[what] == len(prepare(f, opts=opts).lights), what
    assert counts["capped"] < counts["plain"] < len(f.lights) and counts["stochastic"] < counts["plain"]


def test_every_technique_refuses_the_light_rows_in_its_builds_words(monkeypatch):
    f = city_frame()
    v = visible_lights(f)
    monkeypatch.setattr(limits, "MAX_STORAGE_BYTES", v * layouts.GPU_LIGHT.itemsize)
    assert all(t.refusal(f, t.Options(), v) is None for t in REGISTRY.values())      # at the limit
    monkeypatch.setattr(limits, "MAX_STORAGE_BYTES", v * layouts.GPU_LIGHT.itemsize - 1)
    for t in REGISTRY.values():
        why = t.refusal(f, t.Options(), v)
        assert why and why.startswith("light buffer needs"), (t.name, why)
        assert refused_build(t, f, t.Options()) == why, t.name


def test_tiled_refuses_its_cull_loops_as_its_passes_do():
    v = visible_lights(city_frame())
    tiled = REGISTRY["tiled"]
    at = city_frame(loop_budget=(v + 255) // 256 * 10)
    assert tiled.refusal(at, tiled.Options(), v) is None
    f = city_frame(loop_budget=(v + 255) // 256 * 10 - 1)
    why = tiled.refusal(f, tiled.Options(), v)
    assert why.startswith(f"tiled: culling {v} visible lights") and refused_build(tiled, f, tiled.Options()) == why


def test_zbin_refuses_its_depth_test_loops_unless_it_is_off():
    f = city_frame(loop_budget=1)
    v = visible_lights(f)
    zbin = REGISTRY["zbin"]
    why = zbin.refusal(f, zbin.Options(), v)
    assert why.startswith("zbin: the tile depth test") and refused_build(zbin, f, zbin.Options()) == why
    assert zbin.refusal(f, zbin.Options(tile_depth=False), v) is None


def test_the_gpu_build_refuses_in_its_own_words():
    f = city_frame()
    f.context_limits = SimpleNamespace(max_storage_block=len(f.lights) * gpuprep.SCENE_ITEM_BYTES - 1)
    v = visible_lights(f)
    for name in ("clustered", "zbin"):
        t = REGISTRY[name]
        gpu = t.Options(build=1)
        why = t.refusal(f, gpu, v)
        assert why.startswith("--build gpu: the scene's light records"), why
        with pytest.raises(limits.LimitError) as exc:
            t.build(f, gpu)
        assert str(exc.value) == why
        assert t.refusal(f, t.Options(), v) is None          # the CPU build: the constant's limit
