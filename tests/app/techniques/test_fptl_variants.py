"""Feature variants on fptl (--feature-variants, app/techniques/variants.py CELL_PRECOMPUTED):
fptl_lists.comp writes each cell's shape word itself (its packed lists with spill are no CSR
scan), and the shared classification, compaction and per-mask programs shade from it.  Exact
against brute in every fptl_variant and with one loop (type_loops off), on the mask scene
of the variant tests at 16 px tiles (every shape alone and mixed, specular and matte, empty
tiles); the shape word is the CPU's OR over the decoded lists, spill and pool-full cells and
scan windows included; single-tile frames; a per-tile cap; the model figures."""
from dataclasses import replace

import numpy as np
import pytest

from app.exactness import IntendedLoss, check
from app.model import predict
from app.pipeline import features as feat
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, fptl, variants
from cpu_prep import limits
from scenes.model import LIGHT_BOX, LIGHT_TYPES, make_lights
from tests.app.model.replay_check import check as replay_check
from tests.app.techniques.fptl_frames import (CAP_SIZE, capped_crowd, mask_scene, point_crowd, read_lists,
                                              render_checked)
from tests.helpers import CAMERA, assert_exact, make_scene, random_shapes

T, BRUTE = REGISTRY["fptl"], REGISTRY["brute"]
ON = {"feature_variants": True}
# the mask scene at twice the variant tests' size: 16 px tiles then hold what their 8 px did
SIZE = (192, 128)
# (fptl_variant, type_loops): every variant with the chapter's loops, and the one loop
CASES = [(0, True), (1, True), (2, True), (3, True), (0, False)]


def assert_words(r, res, where: str) -> dict:
    """The GPU's shape words equal the CPU's from the lists shading reads (read_lists
    decodes the blocks, the spill and the pool-full state: every light), OR of 1 << type;
    returns the lists."""
    lists, _ = read_lists(r, res)
    types = res.build.lights.type.astype(np.int64)
    want = np.array([np.bitwise_or.reduce(1 << types[idx]) if len(idx) else 0
                     for _, idx in sorted(lists.items())], np.int64)
    got = r.read("cell_features").astype(np.int64)[:res.build.grid.cells]
    bad = np.nonzero(got != want)[0]
    assert not len(bad), f"{where}: {len(bad)} cells' shape words differ, first {bad[0]}: " \
                         f"GPU {got[bad[0]]:#x}, lists {want[bad[0]]:#x}"
    return lists


@pytest.fixture(scope="module")
def renderer(gl):
    with Renderer(mask_scene(SIZE)) as r:
        yield r


@pytest.fixture(scope="module")
def brute(renderer):
    ref = renderer.render(BRUTE)
    assert (ref.contrib_count > 0).sum() > 1000
    return ref


@pytest.mark.parametrize("variant,loops", CASES)
def test_every_mask_is_exact_and_the_words_are_the_lists(renderer, brute, variant, loops):
    res = renderer.render(T, opts=dict(ON, fptl_variant=variant, type_loops=loops))
    where = f"{fptl.VARIANTS[variant]}, type_loops {loops}"
    assert_exact({"brute": brute, "fptl": res}, where)
    assert_words(renderer, res, where)
    s = res.meta["stats"]
    masks = set(s["variant_masks"])
    spec = feat.FEATURE_BITS[feat.SPECULAR]
    singles = {feat.FEATURE_BITS[t] | k for t in LIGHT_TYPES for k in (0, spec)}
    assert {0, spec} | singles <= masks, f"{where}: masks {sorted(masks)} miss some"
    assert any(bin(m & feat.SHAPE_MASK).count("1") > 1 for m in masks), "no mixed-shape tile"
    assert s["feature_variants"] == len(masks) and "variant_fallback" not in s
    assert s["variant_tile"] == fptl.TILE and s["variant_tiles_total"] == 12 * 8
    assert "variant_cells" not in res.meta["gpu_ms"]          # the list pass wrote the words
    assert {"fptl_lists", "variant_classify", "variant_compact"} <= set(res.meta["gpu_ms"])


@pytest.mark.parametrize("variant,loops", CASES)
def test_variants_leave_the_image_and_counters_alone(renderer, variant, loops):
    off = renderer.render(T, opts={"fptl_variant": variant, "type_loops": loops})
    on = renderer.render(T, opts=dict(ON, fptl_variant=variant, type_loops=loops))
    assert np.array_equal(on.image, off.image) and np.array_equal(on.evaluated, off.evaluated)
    assert np.array_equal(on.wave, off.wave)


def test_a_frame_of_no_visible_light_has_only_empty_masks(renderer):
    away = make_lights(3)
    away["position"] = (0.0, 40.0, 60.0)           # behind the camera, out of reach
    res = renderer.render(T, opts=ON, lights=away)
    ref = renderer.render(BRUTE, lights=away)
    assert_exact({"brute": ref, "fptl": res}, "no visible light")
    s = res.meta["stats"]
    assert s["visible_lights"] == 0 and not any(m & feat.SHAPE_MASK for m in s["variant_masks"])
    assert set(s["variant_masks"]) == {0, feat.FEATURE_BITS[feat.SPECULAR]}


def spill_scene():
    """Big points lighting every pixel ahead of random shapes: lit tiles' lists pass 24, the
    first 24 all points (class order), the other shapes in the spill only."""
    rng = np.random.default_rng(5)
    L = np.concatenate([point_crowd(40, radius=9.0), random_shapes(rng, 100, (-14, -1, -34), (14, 7, 6))])
    return make_scene(L, size=(64, 48), camera=CAMERA)


@pytest.mark.parametrize("windows,pool", [(False, 50), (True, None)])
def test_spilled_and_pool_full_cells_words(gl, monkeypatch, windows, pool):
    """The spill's shapes are in the word, a pool-full cell's word is every visible light's
    (a pool of 50 entries: some cells fit, some not), and scan windows carry the word over
    (each dispatch ORs into the last one's)."""
    if pool is not None:
        monkeypatch.setattr(fptl, "SPILL_MAX_ENTRIES", pool)
    with Renderer(spill_scene()) as r:
        if windows:
            monkeypatch.setattr(limits, "DISPATCH_WINDOW", 128)
            if r.frame_input(0, 64).loop_budget is None:
                monkeypatch.setattr(r.limits.__class__, "loop_budget", property(lambda self: 65535))
        res = r.render(T, opts=ON)
        lists = assert_words(r, res, f"spill, windows {windows}")
        flags = r.read("fptl_cells").view(fptl.FPTL_CELL)["flags"]
        words = r.read("cell_features")[:len(flags)].astype(np.int64)
        ref = r.render(BRUTE)
    assert_exact({"brute": ref, "fptl": res}, f"spill, windows {windows}")
    s = res.meta["stats"]
    assert s["spilled_lights"] > 0 and (s["pool_full_cells"] > 0) == (pool is not None)
    assert (len(res.build.own.scans) > 2) == windows
    # some cell has a shape in its spill only: a word of its 24 blocks alone would lack it
    types = res.build.lights.type
    spilled = np.nonzero((flags & fptl.STATE) == fptl.FLAG_SPILLED)[0]
    assert any(set(types[lists[c][24:]]) - set(types[lists[c][:24]]) for c in spilled)
    full = (flags & fptl.FLAG_POOL_FULL) != 0
    assert (words[full] == variants.frame_shape_mask(res.build)).all()


@pytest.mark.parametrize("size", [(8, 8), (5, 3), (1, 1)])
def test_a_single_tile_frame_runs_one_dispatch(gl, size):
    scene = mask_scene(size)
    lamp = make_lights(1)
    lamp["position"], lamp["radius"] = (0.0, 0.5, 0.0), 4.0      # over the view's centre
    with Renderer(scene) as r:
        lights = np.concatenate([scene.lights, lamp])
        res = r.render(T, opts=ON, lights=lights)
        ref = r.render(BRUTE, lights=lights)
    assert_exact({"brute": ref, "fptl": res}, str(size))
    assert (ref.contrib_count > 0).any(), f"{size}: no lit pixel"
    s = res.meta["stats"]
    assert s["variant_dispatches"] == 1 and s["feature_variants"] == 1


def test_a_per_tile_cap_drops_its_lights_from_the_words(gl):
    """hdrp-fptl-24 over 30 points, 3 capsules and 3 boxes that light every pixel: the boxes
    (the punctual category's highest keys) leave every lit tile, and its word; the loss is
    the one the CPU's tile_keep counts, as without variants."""
    L = capped_crowd(30, 3)
    boxes = make_lights(3)
    boxes["type"], boxes["position"] = LIGHT_BOX, L["position"][:3]
    boxes["up"], boxes["extent"], boxes["direction"] = (0.0, 1.0, 0.0), (30.0, 30.0, 30.0), (1.0, 0.0, 0.0)
    with Renderer(make_scene(np.concatenate([L, boxes]), size=CAP_SIZE, camera=CAMERA)) as r:
        off, ref, m_off = render_checked(r, "hdrp-fptl-24")
        opts = T.Options.make(dict(ON, cap_policy="hdrp-fptl-24"))
        res = r.render(T, opts=opts)
        assert_words(r, res, "hdrp-fptl-24")
        m = check(res, ref, r, T, BRUTE, {"opts": opts})
    assert isinstance(m, IntendedLoss), m.message() if m else "a pass"
    assert (m.lights, m.entries, m.tiles, m.pixels) == (m_off.lights, m_off.entries, m_off.tiles, m_off.pixels)
    assert np.array_equal(res.contrib_count, off.contrib_count)
    box = feat.FEATURE_BITS["box"]
    assert (ref.contrib_count > 30).any() and not any(k & box for k in res.meta["stats"]["variant_masks"])
    assert res.meta["stats"]["capped_lights"] == 6 + 3          # points 24-29 and the boxes


def test_every_pass_is_timed_and_modelled(renderer):
    """The classification passes are timed and modelled, variant_cells neither (fptl_lists
    writes the words and its figures count them); the shading replay equals the counters."""
    opts = dict(ON, fptl_variant=2)
    replay_check(renderer, "fptl", opts, 32, "variants")
    res = renderer.render(T, opts=opts)
    on = predict.frame_figures(renderer, T, res, opts, widths=(32,))[32]
    off_res = renderer.render(T, opts={"fptl_variant": 2})
    off = predict.frame_figures(renderer, T, off_res, {"fptl_variant": 2}, widths=(32,))[32]
    timed = set(res.meta["gpu_ms"]) - {"gbuffer"}
    assert timed <= set(on) and "variant_cells" not in on
    assert all(on[n].waves > 0 for n in ("variant_classify", "variant_compact"))
    assert set(on) - set(off) == {"variant_classify", "variant_compact"}
    assert on["fptl_lists"].shared_atomics > off["fptl_lists"].shared_atomics


def test_a_driver_without_indirect_dispatch_runs_the_general_program(renderer, brute, monkeypatch):
    """No classification: the list pass writes no words, the meta says why, still exact."""
    monkeypatch.setattr(renderer, "limits", replace(renderer.limits, indirect_dispatch=False))
    res = renderer.render(T, opts=ON)
    assert_exact({"brute": brute, "fptl": res}, "no indirect dispatch")
    assert "no indirect dispatch" in res.meta["stats"]["variant_fallback"]
    assert not {"variant_classify", "cell_features"} & (set(res.meta["gpu_ms"]) | set(res.meta["bytes"]))
