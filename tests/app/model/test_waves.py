"""The wave replay (app/model/waves.py) against the shaders' own counters: the per-pixel work
it implies (lights evaluated, tree nodes visited) equals PixelStats' at every pixel, on every
builtin scene and for every technique, the native wave path at llvmpipe's subgroup size (8)
included; the lights it finds affecting equal contrib_count up to the float32 rounding of its
copy of the affects test."""
from __future__ import annotations

import numpy as np
import pytest

from app.model import predict, waves
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY
from scenes import BUILTIN_SCENES, load_scene
from tests.app.model.replay_check import check, gl_order

SIZE = (72, 48)                  # 9 x 6 groups: whole 8x8 groups and 4-row halves (W = 32)
LIGHTS = 1536

# Options whose loops the replay walks differently (every technique also runs at defaults).
VARIANTS = [
    ("clustered", {"scalarize": True}), ("clustered", {"duplicated": True}),
    ("tree", {"duplicated": True}), ("tree", {"lights_per_leaf": 1}),
    ("hybrid", {"specialised": False}), ("hybrid", {"scalarize": True}),
    ("hybrid", {"duplicated": True, "radius_scale": 4.0}),
    *[("zbin", {"zbin_variant": v}) for v in (0, 1, 2)], ("zbin", {"printed_mask": True}),
    ("zbin", {"bit_tile": 3}), ("zbin", {"tile_depth": False, "zbin_variant": 2}),
    *[("fptl", {"fptl_variant": v}) for v in (1, 2, 3)], ("fptl", {"type_loops": False}),
    *[("raster", {"raster_variant": v}) for v in (1, 2)], ("raster", {"cluster": True}),
    ("raster", {"zbin_variant": 0}),
]
# The native wave path: waves of llvmpipe's subgroup (8 lanes) vote and scalarize.
NATIVE = [("clustered", {"scalarize": True}), ("hybrid", {}), ("hybrid", {"scalarize": True}),
          *[("zbin", {"zbin_variant": v}) for v in (1, 2, 3)], ("raster", {"zbin_variant": 3})]
NATIVE_WIDTH = 8


@pytest.mark.parametrize("scene", BUILTIN_SCENES)
def test_replay_matches_shader_counters_on_every_scene(gl, scene):
    sc = load_scene(scene, lights=LIGHTS, seed=3)
    with Renderer(sc, SIZE) as r:
        for name in REGISTRY:
            check(r, name, {}, 64, scene)


def test_replay_matches_shader_counters_in_every_variant(gl):
    sc = load_scene("corridor", lights=LIGHTS, seed=5)      # all four shapes, a glossy floor
    with Renderer(sc, SIZE) as r:
        for name, opts in VARIANTS:
            check(r, name, opts, 64, "corridor")


def test_native_path_at_subgroup_size_8(gl):
    """On llvmpipe the native path runs on 8-lane subgroups: the replay at width 8 gives the
    shader's counters (zbin's scalarized loop evaluates its 8-lane wave's union)."""
    from app.pipeline import gl as glmod
    assert glmod.limits().native_ballot, "llvmpipe should offer GL_ARB_shader_ballot"
    sc = load_scene("arena", lights=LIGHTS, seed=7)
    with Renderer(sc, SIZE) as r:
        for name, opts in NATIVE:
            check(r, name, dict(opts, native_wave=True), NATIVE_WIDTH, "arena")


def test_widths_change_only_what_they_should(gl):
    """A per-lane loop's work per pixel is the same at any width; its issued iterations lie
    between the 64-lane wave's and twice it (two 32-lane halves, each as long as its
    longest lane); a scalarized wave evaluates the union of its lanes' lights, so a narrower
    wave evaluates no more at any pixel."""
    sc = load_scene("city", lights=LIGHTS, seed=9)
    with Renderer(sc, SIZE) as r:
        for name, opts in (("clustered", {}), ("tree", {})):
            tech = REGISTRY[name]
            fr = waves.frame_data(r, r.render(tech, 0, opts), tech.resolve_options(opts))
            a, b = (waves.replay(tech.wave_program(fr, w)) for w in (32, 64))
            assert np.array_equal(a.evaluated, b.evaluated) and np.array_equal(a.nodes, b.nodes)
            i32, i64 = a.figures.loops[:, 0].sum(), b.figures.loops[:, 0].sum()
            assert i64 <= i32 <= 2 * i64, (name, i32, i64)
            assert a.figures.waves == 2 * b.figures.waves
        tech = REGISTRY["zbin"]
        fr = waves.frame_data(r, r.render(tech, 0, {}), tech.resolve_options(None))
        a, b = (waves.replay(tech.wave_program(fr, w)) for w in (32, 64))
        assert (a.evaluated <= b.evaluated).all() and a.evaluated.sum() < b.evaluated.sum()
        assert np.array_equal(a.contrib, b.contrib)


def test_figures_count_what_the_loops_do(gl):
    """brute: one scalar load of each light per busy wave, every shading lane active; a
    list technique's light iterations are its longest lanes', its vector loads two each."""
    sc = load_scene("arena", lights=256, seed=1)
    with Renderer(sc, SIZE) as r:
        res = r.render(REGISTRY["brute"], 0)
        fr = waves.frame_data(r, res, REGISTRY["brute"].resolve_options(None))
        f = waves.replay(REGISTRY["brute"].wave_program(fr, 64)).figures
        n = len(res.build.lights)
        light = f.loop("light")
        assert light["issued"] == n * f.busy_waves
        assert light["lanes"] == int(fr.shading.sum()) * n
        assert light["scalar_loads"] == light["issued"] and light["vector_loads"] == 0
        assert light["scalar_lines"] == 2 * light["issued"]         # a 96-B light: two lines
        assert f.unique_bytes["lights"] == -(-n * 96 // 64) * 64
        res = r.render(REGISTRY["clustered"], 0)
        fr = waves.frame_data(r, res, REGISTRY["clustered"].resolve_options(None))
        f = waves.replay(REGISTRY["clustered"].wave_program(fr, 64)).figures
        ev = gl_order(res.evaluated)
        per_wave = np.zeros(f.waves, np.int64)
        wave, _, _ = waves.lanes(SIZE, 64)
        np.maximum.at(per_wave, wave, ev)
        assert f.loop("light")["issued"] == per_wave.sum()
        assert f.loop("light")["lanes"] == ev.sum()
        assert f.loop("light")["vector_loads"] == 2 * per_wave.sum()    # entry, then light
        assert f.loop("cell")["issued"] == f.busy_waves


def test_culling_pass_figures(gl):
    """tiled's tile_cull tests every light in every covered tile twice; fptl's lists prune
    each tile's coarse lights; raster's proxies draw its counted fragments."""
    sc = load_scene("arena", lights=512, seed=2)
    with Renderer(sc, SIZE) as r:
        for name in ("tiled", "fptl", "raster"):
            tech = REGISTRY[name]
            res = r.render(tech, 0)
            figs = predict.frame_figures(r, tech, res)
            for width, passes in figs.items():
                timed = [k for k in res.meta["gpu_ms"] if k != "gbuffer"]
                assert set(passes) - {predict.SHADE} <= {t.split(" (")[0] for t in timed} | \
                    {"raster proxies"}, (name, passes.keys(), timed)
                for f in passes.values():
                    assert f.loops[:, 0].sum() > 0
        n = len(res.build.lights)
        tech = REGISTRY["tiled"]
        res = r.render(tech, 0)
        f = predict.frame_figures(r, tech, res)[64]["tile_cull"]
        pixels, covered, tx, ty = waves.per_tile(waves.frame_data(r, res, tech.resolve_options(None)),
                                                 res.build.grid.tile)
        busy = int((covered > 0).sum())
        assert f.loop("cull_test")["lanes"] == 2 * busy * n


def test_cells_only_frames_replay_like_shaded_ones(gl):
    """A frame rendered with CELLS_ONLY (the benchmark's modelled 1080p runs) records the same
    cells, so its replay equals the shaded frame's, while its light loops did not run."""
    sc = load_scene("hangar", lights=LIGHTS, seed=4)
    with Renderer(sc, SIZE) as r:
        for name in REGISTRY:
            tech = REGISTRY[name]
            full = r.render(tech, 0)
            a = waves.replay(tech.wave_program(waves.frame_data(r, full, tech.resolve_options(None)), 32))
            cells = r.render(tech, 0, defines={"CELLS_ONLY": 1})
            assert np.array_equal(cells.cell, full.cell), name
            assert int(cells.evaluated.sum()) == 0, f"{name}: CELLS_ONLY still shaded"
            b = waves.replay(tech.wave_program(waves.frame_data(r, cells, tech.resolve_options(None)), 32))
            assert np.array_equal(a.evaluated, b.evaluated), name
            assert np.array_equal(a.figures.loops, b.figures.loops), name


def test_a_sampled_replay_stands_for_the_whole_frame(gl):
    """Every k-th group replayed and scaled (the benchmark's heavy and 1080p rows): close to
    the whole replay, and the groups left out add nothing (not even a scalarized loop's
    unguarded words)."""
    sc = load_scene("arena", lights=LIGHTS, seed=11)
    with Renderer(sc, (160, 96)) as r:
        for name, opts in (("clustered", {}), ("tree", {}), ("zbin", {"zbin_variant": 2})):
            tech = REGISTRY[name]
            res = r.render(tech, 0, opts)
            whole = predict.frame_figures(r, tech, res, opts)[64]["shade"]
            part = predict.frame_figures(r, tech, res, opts, sample=3)[64]["shade"]
            for k in range(len(waves.KINDS)):
                a, b = whole.loops[k, 0], part.loops[k, 0]
                assert abs(a - b) <= 0.25 * max(a, 1) + 2, (name, waves.KINDS[k], a, b)
            assert part.busy_waves == pytest.approx(whole.busy_waves, rel=0.25)
