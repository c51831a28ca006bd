"""HDRP FPTL's per-tile caps on fptl (--cap-policy hdrp-fptl-24 / -63, cpu_prep.caps per_tile):
each 16x16 tile keeps, of each category (punctual: point, spot, box; area: capsule), the
lights of the lowest HDRP sort keys up to the budget; the exactness check holds the frame to
brute less exactly the entries the CPU's tile_keep drops, counts the loss, and fails a frame
that keeps other lights.  A tile under its cap is exact."""
from __future__ import annotations

import numpy as np
import pytest

from app.errors import UserError
from app.exactness import IntendedLoss, Mismatch, check
from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, fptl
from cpu_prep import limits
from scenes.model import LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT
from tests.app.techniques.fptl_frames import CAP_SIZE, capped_crowd, render_checked
from tests.helpers import CAMERA, make_scene, random_shapes

T, BRUTE = REGISTRY["fptl"], REGISTRY["brute"]
SIZE = CAP_SIZE






@pytest.mark.parametrize("cap", [24, 63])
def test_each_tile_keeps_each_categorys_lowest_sort_keys(gl, cap):
    points, capsules = cap + 9, cap + 4
    with Renderer(make_scene(capped_crowd(points, capsules), size=SIZE, camera=CAMERA)) as r:
        res, ref, m = render_checked(r, f"hdrp-fptl-{cap}")
        # a pixel every light reaches keeps the first `cap` points and capsules by scene id
        # (HDRP's key: category, GPU type, then the visible index), whatever their depth
        row, x = np.argwhere(ref.contrib_count == points + capsules)[0]
        got = r.render(T, opts={"cap_policy": f"hdrp-fptl-{cap}"}, readback=False,
                       debug_pixel=(int(x), int(row))).debug_lights
    assert isinstance(m, IntendedLoss), m.message() if m else "a pass"
    assert got.tolist() == list(range(cap)) + list(range(points, points + cap))
    st = res.meta["stats"]
    lit_tiles = st["capped_tiles"]
    assert lit_tiles >= 4 and st["capped_entries"] == lit_tiles * (points + capsules - 2 * cap)
    # the GPU's own counts are the CPU's expectation
    assert (m.lights, m.entries, m.tiles) == (st["capped_lights"], st["capped_entries"], lit_tiles)
    assert st["capped_lights"] == points + capsules - 2 * cap == len(res.build.capped_ids)
    assert st["max_pruned"] == 2 * cap and m.pixels > 0 and m.contributions >= m.pixels
    assert (res.contrib_count <= ref.contrib_count).all()
    assert m.message().startswith(f"intended loss: {m.pixels} pixels, {m.lights} lights dropped "
                                  f"by hdrp-fptl-{cap}") and "list entries dropped in" in m.message()


def test_a_tile_under_its_cap_is_exact(gl):
    """The crowd lights the left of the view only; the right's tiles hold a few lights each,
    under the cap: those pixels equal brute, and are lit."""
    rng = np.random.default_rng(5)
    crowd_l = capped_crowd(30, 0)
    crowd_l["position"][:, 0] -= 30.0
    crowd_l["radius"] = 24.0
    few = random_shapes(rng, 16, (2, 0, -16), (9, 4, -4), radius=(3.0, 7.0))
    L = np.concatenate([crowd_l, few])
    with Renderer(make_scene(L, size=SIZE, camera=CAMERA)) as r:
        res, ref, m = render_checked(r, "hdrp-fptl-24")
    assert isinstance(m, IntendedLoss) and m.entries > 0, m.message() if m else "a pass"
    cells = res.build.own.tile_counts["pruned"]          # image order (tiles_y, tiles_x)
    # a capped tile keeps 24 punctual lights: one of fewer dropped none
    under = np.kron(cells < 24, np.ones((16, 16), bool))[:SIZE[1], :SIZE[0]]
    lit = under & (ref.contrib_count > 0)
    assert lit.sum() > 100
    assert (res.contrib_count[under] == ref.contrib_count[under]).all()
    assert (res.contrib_hash[under] == ref.contrib_hash[under]).all()


def test_a_frame_under_every_cap_loses_nothing(gl):
    rng = np.random.default_rng(2)
    L = random_shapes(rng, 40, (-10, 0, -30), (10, 6, 5), radius=(1.0, 6.0))
    with Renderer(make_scene(L, size=SIZE, camera=CAMERA)) as r:
        res, ref, m = render_checked(r, "hdrp-fptl-24")
    assert (ref.contrib_count > 0).mean() > 0.3
    assert isinstance(m, IntendedLoss) and (m.pixels, m.lights, m.entries) == (0, 0, 0)
    assert res.meta["stats"]["capped_entries"] == 0


class DepthOrder(type(T)):
    """fptl whose per-tile cap keeps the nearest lights of a category (its scan in depth
    order), not HDRP's lowest sort keys: the check must fail it."""
    name = "fptl-depth-order"

    def build(self, frame, opts):
        b = super().build(frame, opts)
        b.buffers["fptl_order"] = fptl.class_order(b.lights.type)
        return b


def test_a_tile_that_keeps_other_lights_fails(gl):
    with Renderer(make_scene(capped_crowd(40, 0), size=SIZE, camera=CAMERA)) as r:
        _, _, m = render_checked(r, "hdrp-fptl-24", DepthOrder())
    assert isinstance(m, Mismatch), m
    assert "tile entries hdrp-fptl-24 drops" in m.message() and m.missing and m.extra


def test_scan_windows_carry_the_category_counts(gl, monkeypatch):
    """Over several list-building dispatches (forced here) each cell's category counts carry
    over: the same capped frame, still the intended loss."""
    with Renderer(make_scene(capped_crowd(150, 40, seed=1), size=SIZE, camera=CAMERA)) as r:
        one, _, _ = render_checked(r, "hdrp-fptl-24")
        monkeypatch.setattr(limits, "DISPATCH_WINDOW", 128)
        if r.frame_input(0, 64).loop_budget is None:
            monkeypatch.setattr(r.limits.__class__, "loop_budget", property(lambda self: 65535))
        many, _, m = render_checked(r, "hdrp-fptl-24")
    assert len(many.build.own.scans) > 2
    assert isinstance(m, IntendedLoss) and m.entries > 0, m.message() if m else "a pass"
    assert np.array_equal(one.contrib_hash, many.contrib_hash)
    assert one.meta["stats"]["capped_entries"] == many.meta["stats"]["capped_entries"]


def test_the_scan_order_is_hdrps_key_order_within_each_shape():
    types = np.array([LIGHT_SPOT, LIGHT_POINT, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT], np.uint8)
    ids = np.array([3, 9, 4, 2, 1])                     # the depth order's scene ids
    assert fptl.class_order(types, ids).tolist() == [3, 1, 2, 4, 0]
    assert fptl.class_order(types).tolist() == [1, 3, 2, 0, 4]


@pytest.mark.parametrize("technique, values, says", [
    ("tiled", {"cap_policy": "hdrp-fptl-24"}, "only fptl's list build takes it"),
    ("fptl", {"cap_policy": "hdrp-fptl-63", "fptl_variant": 1}, 'takes --fptl-variant "fine per tile"'),
])
def test_a_per_tile_cap_is_refused_where_no_tile_list_takes_it(technique, values, says):
    with pytest.raises(UserError, match=says) as e:
        REGISTRY[technique].Options.make(values, technique)
    assert "\n" not in str(e.value)


def test_stochastic_culling_under_a_per_tile_cap_is_the_counted_loss_of_its_draw(gl):
    """The cap acts on the lists the draw's ranges build; the check renders brute and the
    exact lists with the same draw: still exactly the tile cap's loss.  A view cap with a
    draw stays refused."""
    L = capped_crowd(40, 30, seed=4)
    L["intensity"] = np.linspace(1.0, 8.0, len(L))
    with Renderer(make_scene(L, size=SIZE, camera=CAMERA)) as r:
        opts = T.Options.make({"cap_policy": "hdrp-fptl-24", "stochastic": 256, "stochastic_frame": 3})
        res = r.render(T, opts=opts)
        m = check(res, r.render(BRUTE), r, T, BRUTE, {"opts": opts})
    assert res.meta["stats"]["stochastic_t"] == 1 / 256
    assert isinstance(m, IntendedLoss) and m.entries > 0 and m.pixels > 0, m.message() if m else "a pass"
    assert m.entries == res.meta["stats"]["capped_entries"]
    with pytest.raises(UserError, match="not offered together"):
        T.Options.make({"cap_policy": "urp-16", "stochastic": 4})
