"""Per-tile feature variants (--feature-variants, app/techniques/variants.py): exact against
brute in every mask a frame holds (each shape alone and mixed, specular and matte, empty
tiles of sky and of unlit floor, hybrid's list / tree / mixed tiles), one dispatch when
every tile has one mask (single-tile frames), the general program where a mask has none or
the driver cannot dispatch indirectly, and the figures the report reads."""
from dataclasses import replace

import numpy as np
import pytest

from app.model import predict
from app.pipeline import features as feat
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, variants
from scenes.model import LIGHT_TYPES
from tests.app.model.replay_check import check as replay_check
from tests.app.techniques.fptl_frames import mask_scene
from tests.helpers import assert_exact

SIZE = (96, 64)
ON = {"feature_variants": True}
# 8-px tiles: each tile one list, so the frame holds many masks on 96 x 64 pixels
CASES = {"tiled": dict(ON, tile=8), "clustered": dict(ON, tile=8), "zbin": dict(ON),
         "hybrid": dict(ON, tile=8, radius_scale=8.0, lights_per_leaf=1)}




@pytest.fixture(scope="module")
def renderer(gl):
    """One renderer of the mask scene: its program cache compiles each variant once."""
    with Renderer(mask_scene()) as r:
        yield r


@pytest.fixture(scope="module")
def frames(renderer):
    """brute and each technique with variants on, on the mask scene."""
    out = {"brute": renderer.render(REGISTRY["brute"])}
    out.update({n: renderer.render(REGISTRY[n], opts=o) for n, o in CASES.items()})
    return out


def test_each_shape_lights_the_mask_scene(renderer):
    """The scene's lights of every shape reach pixels (a mask whose lights touch nothing
    would prove nothing)."""
    for shape in LIGHT_TYPES:
        lit = renderer.render(REGISTRY["brute"], lights=mask_scene(shapes=(shape,)).lights)
        assert (lit.contrib_count > 0).sum() > 20, shape


@pytest.mark.parametrize("name", list(CASES))
def test_every_mask_is_exact(frames, name):
    assert_exact({"brute": frames["brute"], name: frames[name]}, name)
    stats = frames[name].meta["stats"]
    masks = set(stats["variant_masks"])
    kinds = {(m >> feat.CELL_KIND_SHIFT) & 3 for m in masks}
    plain = {m & (feat.SHAPE_MASK | feat.FEATURE_BITS["specular"]) for m in masks}
    spec = feat.FEATURE_BITS["specular"]
    singles = {feat.FEATURE_BITS[t] | s for t in LIGHT_TYPES for s in (0, spec)}
    assert {0, spec} | singles <= plain, f"{name}: masks {sorted(masks)} miss some"
    assert any(bin(m & feat.SHAPE_MASK).count("1") > 1 for m in masks), "no mixed-shape tile"
    assert stats["feature_variants"] == len(masks) and "variant_fallback" not in stats
    if name == "hybrid":
        assert {1, 2, 3} <= kinds, f"hybrid: cell kinds {kinds} (lists, trees, mixed)"
    assert (frames["brute"].contrib_count > 0).sum() > 300


@pytest.mark.parametrize("name", list(CASES))
def test_variants_leave_the_image_and_counters_alone(frames, renderer, name):
    """The same loops over the same lists: the same image and evaluated lights (a mask's
    program that skipped a shape's or the specular lobe's shading would keep the light sets
    and change the image)."""
    off = renderer.render(REGISTRY[name], opts={k: v for k, v in CASES[name].items() if k not in ON})
    on = frames[name]
    assert off.meta["options"]["feature_variants"] is False and on.meta["options"]["feature_variants"] is True
    assert np.array_equal(on.image, off.image) and np.array_equal(on.evaluated, off.evaluated)
    assert np.array_equal(on.wave, off.wave)


def test_figures_count_what_each_program_compiled(frames):
    """On 8-px tiles of one list each, no pixel's program has a shape its list lacks; the
    general program has both kinds of waste here, and variants cut the specular one."""
    s = frames["tiled"].meta["stats"]
    assert s["variant_shape_waste"] == 0.0 < s["variant_shape_waste_off"]
    assert 0.0 <= s["variant_specular_waste"] < s["variant_specular_waste_off"]
    assert sum(s["variant_tiles"].values()) == 12 * 8       # every 8-px tile of 96 x 64


@pytest.mark.parametrize("size", [(8, 8), (5, 3), (1, 1)])
def test_a_single_tile_frame_runs_one_dispatch(gl, size):
    with Renderer(mask_scene(size)) as r:
        res = r.render(REGISTRY["tiled"], opts=dict(ON, tile=8))
        ref = r.render(REGISTRY["brute"])
    assert_exact({"brute": ref, "tiled": res}, str(size))
    s = res.meta["stats"]
    assert s["variant_dispatches"] == 1 and s["feature_variants"] == 1


def test_masks_past_the_program_cap_run_the_general_program(frames, renderer, monkeypatch):
    monkeypatch.setattr(variants, "MAX_PROGRAMS", 2)
    res = renderer.render(REGISTRY["clustered"], opts=CASES["clustered"])
    assert_exact({"brute": frames["brute"], "clustered": res}, "capped programs")
    s = res.meta["stats"]
    assert s["feature_variants"] == 2 and len(s["variant_masks"]) > 2
    assert "general program" in s["variant_fallback"]


def test_a_driver_without_indirect_dispatch_runs_the_general_program(frames, renderer, monkeypatch):
    monkeypatch.setattr(renderer, "limits", replace(renderer.limits, indirect_dispatch=False))
    res = renderer.render(REGISTRY["zbin"], opts=ON)
    assert_exact({"brute": frames["brute"], "zbin": res}, "no indirect dispatch")
    assert "no indirect dispatch" in res.meta["stats"]["variant_fallback"]
    assert "variant_classify" not in res.meta["gpu_ms"] and "variant_masks" not in res.meta["stats"]


def test_every_pass_is_timed_and_modelled(frames, renderer):
    """The three classification passes are timed as passes and have model figures; the
    shading replay still equals the shader's counters."""
    replay_check(renderer, "hybrid", CASES["hybrid"], 32, "variants")
    res = renderer.render(REGISTRY["hybrid"], opts=CASES["hybrid"])
    figures = predict.frame_figures(renderer, REGISTRY["hybrid"], res, CASES["hybrid"], widths=(32,))
    names = ("variant_cells", "variant_classify", "variant_compact")
    assert set(names) <= set(res.meta["gpu_ms"]) and set(names) <= set(figures[32])
    assert all(figures[32][n].waves > 0 for n in names)


def test_a_tile_the_groups_do_not_tile_classifies_on_hdrps_16(gl):
    """tile 12 is not a multiple of the 8x8 group: the variant tile is HDRP's 16, each the
    union of the 12-px lists its pixels read."""
    with Renderer(mask_scene((48, 40))) as r:
        res = r.render(REGISTRY["tiled"], opts=dict(ON, tile=12))
        ref = r.render(REGISTRY["brute"])
    assert_exact({"brute": ref, "tiled": res}, "tile 12")
    s = res.meta["stats"]
    assert s["variant_tile"] == variants.HDRP_TILE and s["variant_tiles_total"] == 3 * 3
    assert s["variant_dispatches"] > 1 and (ref.contrib_count > 0).any()
