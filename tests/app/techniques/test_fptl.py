"""fptl (Mikkelsen, GPU Pro 7, "Fine Pruned Tiled Light Lists"): its own checks beyond the
registry-wide exactness suites (which include it: test_exactness, test_shapes,
test_hard_cases, test_loop_budget).

  * layouts: the generated GLSL structs against std430; shape classes, index widths, the
    CPU's tile counts and spill bound;
  * the GPU AABB pass is conservative (points sampled inside every shape's volume project
    inside its rectangle and depth range) and tight (a narrow spot's rectangle is far
    smaller than its bounding sphere's);
  * the lists are the chapter's: a tile's fine list is exactly the set of lights that
    affect some pixel of the tile (the perfect culler's per-pixel lists, united per tile),
    in shape-class order, packed as R10G10B10A2 blocks whose 2-bit counts are right;
  * shading reads the lists as stored: the length and the spill / pool-full state are in
    band in the words (every state's encoding decodes back, and agrees with the cells'
    records, which the shading pass does not bind); the bytes it reads per tile (stat
    shade_bytes_per_tile) are the chapter's 32 B, plus the spill where there is one;
  * every cap overflows and stays exact: coarse lists past 64, pruned lists past 24 (the
    spill), a spill pool that runs short (the cell shades every light), more than 1,024
    visible lights (16-bit indices) and the 32-bit format, scan windows on a loop-limited
    driver; all counted in the meta stats;
  * the variants: coarse-only evaluates the coarse lists, per-cell lists are subsets of the
    tile's, all exact; the per-tile counts for heat maps.
"""
from __future__ import annotations

import numpy as np
import pytest

from app.pipeline.renderer import Renderer
from app.techniques import REGISTRY, fptl
from cpu_prep import layouts, limits
from cpu_prep.camera import frame_camera, look_at
from scenes.geometry import box_mesh
from scenes.model import LIGHT_BOX, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_SPOT, make_lights
from tests.app.techniques.fptl_frames import point_crowd, read_lists
from tests.helpers import CAMERA, affects64, assert_exact, make_scene, random_shapes, render_on

T = REGISTRY["fptl"]


# ---------------------------------------------------------------------------- no GL

def test_structs_match_std430():
    text = fptl.structs_glsl()
    for name, dtype in fptl.STRUCTS.items():
        offsets, stride = layouts.std430_offsets(dtype)
        assert stride == dtype.itemsize, name
        assert all(offsets[f] == dtype.fields[f][1] for f in dtype.names), name
        assert f"struct {name} {{" in text
    assert fptl.FPTL_AABB.itemsize == 32 and fptl.FPTL_CELL.itemsize == 16


def test_class_order_sorts_by_shape_class_stably():
    types = np.array([LIGHT_BOX, LIGHT_POINT, LIGHT_SPOT, LIGHT_CAPSULE, LIGHT_POINT, LIGHT_BOX,
                      LIGHT_SPOT], np.uint8)
    order = fptl.class_order(types)
    # sphere/capsule first (points, then capsules), then cones, then boxes; depth order
    # (input order) within a shape: the shading's per-type loop order
    assert order.tolist() == [1, 4, 3, 2, 6, 0, 5]
    assert fptl.class_order(np.zeros(0, np.uint8)).size == 0


@pytest.mark.parametrize("n,bits,words", [(0, 10, 8), (1024, 10, 8), (1025, 16, 13),
                                          (65536, 16, 13), (65537, 32, 25)])
def test_index_widths(n, bits, words):
    assert fptl.index_bits(n) == bits
    assert fptl.list_words(bits) == words
    # the chapter's 8 blocks hold 24 with no count word; the wide formats' count word first
    assert (words - fptl.head_words(bits)) * (32 // bits) == fptl.LIST_CAP
    assert fptl.head_words(bits) == (0 if bits == 10 else 1)


def encode(listed: int, state: int, bits: int) -> np.ndarray:
    """One cell's words as fptl_lists.comp writes them (fptl_common.glsl fptl_block_count,
    fptl_count_word), indices 5, 6, 7, ... in its slots."""
    per, w = 32 // bits, np.zeros(fptl.list_words(bits), np.uint32)
    h = fptl.head_words(bits)
    for k in range(fptl.LIST_CAP if state else listed):
        w[h + k // per] |= np.uint32((5 + k) << (k % per) * bits % 32)
    if bits == 10:
        for b in range(8):
            c = (fptl.POOL_FULL_COUNTS[b] if state & fptl.FLAG_POOL_FULL else
                 fptl.SPILLED_COUNTS[b] if state & fptl.FLAG_SPILLED else min(max(listed - 3 * b, 0), 3))
            w[b] = (int(w[b]) & 0x3FFFFFFF) | c << 30
    else:
        w[0] = (0 if state & fptl.FLAG_POOL_FULL else listed) | state << 8
    return w


@pytest.mark.parametrize("bits", [10, 16, 32])
def test_list_state_is_in_band_and_decodes_back(bits):
    """Every plain length 0-24, a spilled list and a pool-full cell: the words alone give the
    length and the state (decode_state = the shader's decoding), and the 10-bit states are
    count patterns no plain list has (an empty block 0 before full blocks), with every
    slot still a light."""
    cases = [(k, 0) for k in range(fptl.LIST_CAP + 1)] + \
        [(fptl.LIST_CAP, fptl.FLAG_SPILLED), (fptl.LIST_CAP, fptl.FLAG_SPILLED | fptl.FLAG_POOL_FULL)]
    words = np.stack([encode(k, st, bits) for k, st in cases])
    listed, state = fptl.decode_state(words, bits)
    want_state = [st for _, st in cases]
    assert state.tolist() == want_state
    assert listed.tolist() == [0 if st & fptl.FLAG_POOL_FULL else k for k, st in cases]
    idx, _ = fptl.decode_lists(words, bits)
    assert idx[-2].tolist() == list(range(5, 5 + fptl.LIST_CAP))      # a spilled list keeps 24
    if bits == 10:
        patterns = {tuple((w >> 30).tolist()) for w in words}
        assert len(patterns) == len(cases)
        assert tuple((words[-2] >> 30).tolist()) == fptl.SPILLED_COUNTS
    lst, spill = fptl.shade_bytes(words, np.zeros((1, len(cases), 2), np.uint32), bits)
    if bits == 10:
        assert (lst == 32).all()                         # the chapter's 32 B, whole
    else:
        per = 32 // bits
        assert lst.tolist() == [4 + (0 if st & fptl.FLAG_POOL_FULL else 4 * -(-k // per))
                                for k, st in cases]
    assert spill.tolist() == [8 if st == fptl.FLAG_SPILLED else 0 for _, st in cases]


def test_tile_counts_match_a_direct_count(rng):
    from cpu_prep import grid as gridmod
    cam = frame_camera(CAMERA, 100, 70)
    g = gridmod.make_grid(cam, 16, 1, 100.0, 5.0)
    x0 = rng.uniform(-40, 130, 300)
    y0 = rng.uniform(-40, 100, 300)
    rect = np.column_stack([x0, x0 + rng.uniform(-5, 60, 300), y0, y0 + rng.uniform(-5, 60, 300)])
    zero = np.zeros(len(rect))
    got = gridmod.rect_counts(g, rect, zero, zero)[..., 0]
    want = np.zeros((g.tiles_y, g.tiles_x), int)
    for ty in range(g.tiles_y):
        for tx in range(g.tiles_x):
            # pixel p (centre p + 0.5) in tile p // 16: the tile spans [16 tx, 16 tx + 16),
            # the last one's part past the image's edge too (cpu_prep.grid's rule: bounds)
            lo_x, hi_x = 16 * tx, 16 * tx + 16
            lo_y, hi_y = 16 * ty, 16 * ty + 16
            want[ty, tx] = int(((rect[:, 0] < hi_x) & (rect[:, 1] >= lo_x) & (rect[:, 0] <= rect[:, 1])
                                & (rect[:, 2] < hi_y) & (rect[:, 3] >= lo_y) & (rect[:, 2] <= rect[:, 3])).sum())
    assert np.array_equal(got, want)
    assert fptl.spill_bound(got) == int(np.maximum(want - 24, 0).sum())
    # with depth slices: a light counts in the slices its depth range meets
    g16 = gridmod.make_grid(cam, 16, 16, 100.0, 5.0)
    d_lo = rng.uniform(0.05, 80, 300)
    d_hi = d_lo + rng.uniform(0, 30, 300)
    got16 = gridmod.rect_counts(g16, rect, d_lo, d_hi)
    s0, s1 = g16.slice_of(d_lo * (1 - 1e-4)), g16.slice_of(d_hi * (1 + 1e-4))
    for ty, tx, sl in [(0, 0, 0), (2, 3, 5), (4, 6, 15), (1, 2, 9)]:
        lo_x, hi_x, lo_y, hi_y = 16 * tx, 16 * tx + 16, 16 * ty, 16 * ty + 16
        want16 = ((rect[:, 0] < hi_x) & (rect[:, 1] >= lo_x) & (rect[:, 0] <= rect[:, 1])
                  & (rect[:, 2] < hi_y) & (rect[:, 3] >= lo_y) & (rect[:, 2] <= rect[:, 3])
                  & (s0 <= sl) & (s1 >= sl)).sum()
        assert got16[ty, tx, sl] == want16
    assert (got16.max(2) <= got).all()


# ---------------------------------------------------------------------------- helpers

def shapes_scene(rng, n=160, size=(96, 64), **kw):
    return make_scene(random_shapes(rng, n, (-14, -1, -34), (14, 7, 6), **kw), size=size, camera=CAMERA)


def render(r, opts=None, lights=None):
    return r.render(T, 0, T.resolve_options(opts or {}), lights=lights)




def expected_shade_bytes(r, res, lists_of):
    """What shading reads per lit tile (image order) from the decoded lists: the list's
    words (32 B at 10 bits; wide: the count word and the index words filled), a spilled
    cell's heads (8 B a scan window) and spill (4 B an entry)."""
    st, b = res.meta["stats"], res.build
    bits, g = st["index_bits"], b.grid
    cells = r.read("fptl_cells").view(fptl.FPTL_CELL)
    scans = len(b.own.scans)
    per_cell = np.zeros(len(cells), np.int64)
    for c, rec in enumerate(cells):
        if not rec["flags"] & fptl.FLAG_COVERED:
            continue
        if rec["flags"] & fptl.FLAG_POOL_FULL:
            per_cell[c] = 32 if bits == 10 else 4
            continue
        k = len(lists_of[c])
        per_cell[c] = 32 if bits == 10 else 4 + 4 * -(-min(k, 24) // (32 // bits))
        if k > 24:
            per_cell[c] += 8 * scans + 4 * (k - 24)
    t = per_cell.reshape(g.tiles_y, g.tiles_x, g.slices).sum(2)[::-1]
    return t[b.own.tile_counts["coarse"] > 0]


def perfect_tile_sets(r, tiles_x, tiles_y):
    """{tile: set of light indices affecting some pixel of it} from the perfect culler's
    exact per-pixel lists (evaluate_light itself decides), GL tile order."""
    res = r.render(REGISTRY["perfect"])
    assert res.meta["stats"]["bands"] == 1
    w, h = r.size
    ranges = r.read("perfect_ranges_0").reshape(h, w, 2)
    entries = r.read("perfect_entries_0")
    sets = {t: set() for t in range(tiles_x * tiles_y)}
    for y in range(h):
        for x in range(w):
            a, k = ranges[y, x]
            sets[(y // 16) * tiles_x + x // 16].update(entries[a:a + k].tolist())
    return sets, res


def class_key(build):
    """Position of each light index in the class order (the lists' order)."""
    pos = np.empty(len(build.lights), np.int64)
    pos[build.buffers["fptl_order"]] = np.arange(len(build.lights))
    return pos


# ---------------------------------------------------------------------------- the AABB pass

def _sample_inside(rng, light, view, center, radius, k=3000):
    """View-space points inside one light's volume (float64), sampled in its bound sphere."""
    u = rng.normal(size=(k, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    P = center + u * (radius * rng.uniform(0, 1, k) ** (1 / 3))[:, None]
    inside, near = affects64(P, light[None], view)
    return P[inside[:, 0] & ~near[:, 0]]


@pytest.mark.parametrize("seed", [1, 2])
def test_light_aabbs_are_conservative_for_every_shape(gl, seed):
    """Points inside each light's volume (and in front of the near plane, on screen) project
    inside its GPU rectangle and depth range: lights around and behind the eye, through the
    near plane, far away, narrow and wide spots, long capsules, flat boxes."""
    rng = np.random.default_rng(seed)
    eye = np.array(CAMERA.position)
    lights = np.concatenate([
        random_shapes(rng, 120, (-14, -1, -34), (14, 7, 6)),
        random_shapes(rng, 40, eye - 2.0, eye + 2.0, radius=(0.5, 4.0), length=(0.5, 6.0),
                      extent=(0.3, 4.0)),
        random_shapes(rng, 20, (-60, -5, -190), (60, 30, -120), radius=(2.0, 20.0))])
    scene = make_scene(lights, size=(96, 64), camera=CAMERA)
    with Renderer(scene) as r:
        res = render(r)
        aabbs = r.read("fptl_aabbs").view(fptl.FPTL_AABB)
    b = res.build
    cam = b.frame.camera
    view = cam.view_from_world
    w, h = cam.width, cam.height
    checked = 0
    for a in aabbs:
        i = int(a["light"])
        L = lights[int(b.lights.ids[i])]
        P = _sample_inside(rng, L, view, b.lights.center[i], b.lights.bound_radius[i])
        depth = -P[:, 2]
        sx = (P[:, 0] / (depth * cam.tan_half_x) * 0.5 + 0.5) * w
        sy = (P[:, 1] / (depth * cam.tan_half_y) * 0.5 + 0.5) * h
        seen = (depth >= cam.near) & (depth <= cam.far) & (sx >= 0) & (sx <= w) & (sy >= 0) & (sy <= h)
        if not seen.any():
            continue
        x0, x1, y0, y1 = a["rect"]
        d0, d1 = a["depth"]
        out = seen & ((sx < x0) | (sx > x1) | (sy < y0) | (sy > y1) | (depth < d0) | (depth > d1))
        assert not out.any(), (f"light {i} (type {L['type']}): {int(out.sum())} inside points "
                               f"outside its AABB {a['rect']} {a['depth']}")
        checked += 1
    assert checked > 100


def test_narrow_spot_aabbs_are_tighter_than_their_spheres(gl):
    """The chapter's point: a narrow spot's sphere is a bad bound; its scaled OBB clipped to
    the frustum gives a far smaller rectangle (gallery-like spots looking down)."""
    rng = np.random.default_rng(7)
    n = 30
    L = make_lights(n)
    L["type"] = LIGHT_SPOT
    L["position"] = np.column_stack([rng.uniform(-8, 8, n), np.full(n, 6.0), rng.uniform(-25, -8, n)])
    L["direction"] = (0.0, -1.0, 0.0)
    L["radius"] = 8.0
    L["cos_outer"] = np.cos(np.radians(rng.uniform(4, 12, n)))
    L["cos_inner"] = L["cos_outer"]
    scene = make_scene(L, size=(128, 96), camera=CAMERA)
    with Renderer(scene) as r:
        res = render(r)
        aabbs = r.read("fptl_aabbs").view(fptl.FPTL_AABB)
    rect = res.build.lights.rect                        # the CPU's rectangles (sphere ∩ pyramid)
    from cpu_prep.bounds import screen_rects
    cam = res.build.frame.camera
    sx0, sx1, sy0, sy1 = screen_rects(res.build.lights.center, res.build.lights.bound_radius, cam)
    ratios = []
    for a in aabbs:
        i = int(a["light"])
        x0, x1, y0, y1 = np.clip(a["rect"], [0, 0, 0, 0], [128, 128, 96, 96])
        s = np.clip([sx0[i], sx1[i], sy0[i], sy1[i]], [0, 0, 0, 0], [128, 128, 96, 96])
        ratios.append(max(x1 - x0, 0) * max(y1 - y0, 0) / max((s[1] - s[0]) * (s[3] - s[2]), 1e-9))
        # not looser than the CPU's own conservative rectangle by more than the pixel margins
        assert x1 - x0 <= rect[i, 1] - rect[i, 0] + 4 and y1 - y0 <= rect[i, 3] - rect[i, 2] + 4
    assert np.median(ratios) < 0.5, ratios


# ---------------------------------------------------------------------------- the lists

@pytest.mark.parametrize("n", [1, 120, 400])
def test_fine_lists_are_exactly_the_lights_of_the_tile_in_class_order(gl, n):
    rng = np.random.default_rng(n)
    scene = shapes_scene(rng, n, size=(80, 48))
    with Renderer(scene) as r:
        sets, _ = perfect_tile_sets(r, 5, 3)
        res = render(r)
        lists, cells = read_lists(r, res)
        shade_bytes = expected_shade_bytes(r, res, lists)
        ref = render_on(r, techniques=["brute"])
    assert_exact({"brute": ref["brute"], "fptl": res}, f"{n} shapes")
    key = class_key(res.build)
    for t, want in sets.items():
        got = lists[t]
        assert set(got) == want and len(got) == len(want), f"tile {t}: {sorted(got)} != {sorted(want)}"
        assert list(key[got]) == sorted(key[got]), f"tile {t}: not in class order"
    st = res.meta["stats"]
    assert st["pruned_entries"] == sum(len(s) for s in sets.values())
    # shading reads the chapter's 32 B a lit tile, and a spilled tile's spill besides
    assert st["index_bits"] == 10 and st["shade_list_bytes_per_tile"] == 32.0
    assert st["shade_bytes_per_tile"] == pytest.approx(shade_bytes.mean())
    assert (st["shade_spill_bytes_per_tile"] == 0) == (st["pruned_overflow_cells"] == 0)
    assert (shade_bytes > 32).sum() == st["pruned_overflow_cells"]
    assert st["coarse_entries"] >= st["pruned_entries"]
    assert (cells["coarse"] >= cells["pruned"]).all()
    if n >= 120:
        assert st["coarse_entries"] > st["pruned_entries"] > 0


def test_per_tile_counts_for_heat_maps(gl, rng):
    """build.own.tile_counts (image order) and the per-pixel evaluated counts agree: in
    the fine per-tile variant every covered pixel evaluates its tile's pruned list."""
    scene = shapes_scene(rng, 200, size=(80, 48))
    with Renderer(scene) as r:
        res = render(r)
    t = res.build.own.tile_counts
    assert t["coarse"].shape == t["pruned"].shape == (3, 5)
    assert (t["coarse"] >= t["pruned"]).all()
    per_pixel = np.repeat(np.repeat(t["pruned"], 16, 0), 16, 1)[:48, :80]
    covered = res.depth > 0
    assert np.array_equal(res.evaluated[covered], per_pixel[covered])
    st = res.meta["stats"]
    assert st["coarse_entries"] == t["coarse"].sum() and st["pruned_entries"] == t["pruned"].sum()
    assert res.meta["bytes"]["fptl_lists"] == 15 * 32          # the chapter's 32 B a tile
    assert {"light_aabb", "fptl_lists", "shade"} <= set(res.meta["gpu_ms"])


# ---------------------------------------------------------------------------- caps overflow

def in_view(rng, n, aspect, depth=(5.0, 30.0)):
    """World positions of n points well inside CAMERA's view."""
    cam = frame_camera(CAMERA, 100, int(100 / aspect))
    d = rng.uniform(*depth, n)
    v = np.column_stack([rng.uniform(-0.8, 0.8, n) * d * cam.tan_half_x,
                         rng.uniform(-0.8, 0.8, n) * d * cam.tan_half_y, -d])
    m = np.linalg.inv(cam.view_from_world)
    return v @ m[:3, :3].T + m[:3, 3]




def test_coarse_past_64_and_pruned_past_24_spill_and_stay_exact(gl):
    n = 150
    L = point_crowd(n)
    with Renderer(make_scene(L, size=(48, 32), camera=CAMERA)) as r:
        res = render(r)
        lists, cells = read_lists(r, res)
        want = expected_shade_bytes(r, res, lists)
        ref = render_on(r, techniques=["brute"])
    assert_exact({"brute": ref["brute"], "fptl": res}, "crowded tiles")
    st = res.meta["stats"]
    covered = res.depth > 0
    lit = (ref["brute"].contrib_count > 0).reshape(2, 16, 3, 16).any((1, 3))[::-1].ravel()  # GL tiles
    k = int(lit.sum())
    assert st["visible_lights"] == n and k >= 4
    assert st["coarse_overflow_tiles"] >= k and st["pruned_overflow_cells"] == k
    assert st["spilled_lights"] == k * (n - 24) and st["pool_full_cells"] == 0
    assert st["spill_used"] == k * (n - 24) <= st["spill_capacity"]
    flags = cells["flags"][lit]
    assert (flags & fptl.FLAG_COARSE_OVER).all() and (flags & fptl.FLAG_SPILLED).all()
    # a spilled tile reads its 32 B, each scan window's head and its spill, nothing more
    assert st["shade_bytes_per_tile"] == pytest.approx(want.mean())
    assert st["shade_bytes_max_tile"] == want.max() == 32 + 8 * len(res.build.own.scans) + 4 * (n - 24)
    lit_px = res.contrib_count > 0
    assert (res.evaluated[lit_px] == n).all() and (res.contrib_count == n).mean() > 0.5
    assert all(sorted(v) == list(range(n)) for t, v in lists.items() if lit[t])


@pytest.mark.parametrize("variant", [0, 1, 2, 3])
def test_the_spill_pool_bound_holds_in_every_variant(gl, variant):
    """The pool is sized from the CPU's rectangles (fptl.spill_bound): crowded tiles, lights
    around the eye and through the near plane never run it short, in any variant."""
    rng = np.random.default_rng(variant)
    eye = np.array(CAMERA.position)
    L = np.concatenate([point_crowd(90, radius=10.0, seed=variant),
                        random_shapes(rng, 60, eye - 1.5, eye + 1.5, radius=(0.3, 3.0)),
                        random_shapes(rng, 150, (-14, -1, -34), (14, 7, 6))])
    with Renderer(make_scene(L, size=(64, 48), camera=CAMERA)) as r:
        res = render(r, {"fptl_variant": variant})
        ref = render_on(r, techniques=["brute"])
    assert_exact({"brute": ref["brute"], "fptl": res}, fptl.VARIANTS[variant])
    st = res.meta["stats"]
    assert st["pool_full_cells"] == 0 and st["spilled_lights"] > 0
    assert st["spilled_lights"] == st["spill_used"] <= st["spill_capacity"]


@pytest.mark.parametrize("capacity", [0, 200])
def test_a_short_spill_pool_flags_cells_that_shade_every_light(gl, monkeypatch, capacity):
    monkeypatch.setattr(fptl, "SPILL_MAX_ENTRIES", capacity)
    rng = np.random.default_rng(capacity)
    L = np.concatenate([point_crowd(60, radius=9.0), random_shapes(rng, 100, (-14, -1, -34), (14, 7, 6))])
    with Renderer(make_scene(L, size=(64, 48), camera=CAMERA)) as r:
        res = render(r)
        _, cells = read_lists(r, res)
        ref = render_on(r, techniques=["brute"])
    assert_exact({"brute": ref["brute"], "fptl": res}, f"spill pool of {capacity}")
    st = res.meta["stats"]
    full = (cells["flags"] & fptl.FLAG_POOL_FULL) != 0
    assert st["pool_full_cells"] == int(full.sum()) > 0
    assert st["spill_capacity"] == capacity and st["spill_used"] <= capacity
    if capacity:
        assert not full.all(), "some cells should fit a pool of 200"
    # a flagged tile's pixels evaluate every visible light
    flagged = np.repeat(np.repeat(full.reshape(3, 4)[::-1], 16, 0), 16, 1)
    covered = res.depth > 0
    assert (res.evaluated[flagged & covered] == st["visible_lights"]).all()


@pytest.mark.parametrize("n,bits", [(1024, 10), (1025, 16)])
def test_more_than_1024_visible_lights_take_16_bit_indices(gl, n, bits):
    """At 1,024 visible lights the chapter's 10-bit blocks; at 1,025 the 16-bit format, never
    a wrapped index.  Small lights on the floor plus a few big ones: short lists."""
    rng = np.random.default_rng(n)
    L = random_shapes(rng, n, (0, 0, 0), (1, 1, 1), radius=(0.2, 1.5), length=(0, 2), extent=(0.1, 1.0))
    L["position"] = in_view(rng, n, 48 / 32)
    L["position"][:8] = (0.0, 1.0, -6.0)
    L["radius"][:8], L["type"][:8] = 30.0, LIGHT_POINT
    L["position"][8] = in_view(rng, 1, 48 / 32, depth=(45.0, 45.0))[0]    # the last in depth
    L["radius"][8], L["type"][8] = 50.0, LIGHT_POINT                      # order, lights much
    with Renderer(make_scene(L, size=(48, 32), camera=CAMERA)) as r:
        sets, _ = perfect_tile_sets(r, 3, 2)
        res = render(r)
        lists, _ = read_lists(r, res)
        ref = render_on(r, techniques=["brute"])
    assert res.meta["stats"]["visible_lights"] == n, "the case needs every light visible"
    assert res.meta["stats"]["index_bits"] == bits
    assert res.meta["bytes"]["fptl_lists"] == 6 * fptl.list_words(bits) * 4
    assert_exact({"brute": ref["brute"], "fptl": res}, f"{n} lights")
    assert max(max(v) for v in lists.values() if v) == n - 1
    for t, want in sets.items():
        assert set(lists[t]) == want


def test_32_bit_indices(gl, monkeypatch):
    """The 32-bit format (past 65,536 visible lights), forced on a small frame."""
    monkeypatch.setattr(fptl.lists, "INDEX10_MAX", 4)         # the formats live in fptl.lists
    monkeypatch.setattr(fptl.lists, "INDEX16_MAX", 8)
    rng = np.random.default_rng(32)
    scene = shapes_scene(rng, 200, size=(48, 32))
    with Renderer(scene) as r:
        sets, _ = perfect_tile_sets(r, 3, 2)
        res = render(r)
        lists, _ = read_lists(r, res)
        ref = render_on(r, techniques=["brute"])
    assert res.meta["stats"]["index_bits"] == 32
    assert_exact({"brute": ref["brute"], "fptl": res}, "32-bit indices")
    for t, want in sets.items():
        assert set(lists[t]) == want


def test_scan_windows_give_the_same_lists(gl, monkeypatch):
    """On a loop-limited driver list building runs in scan windows carrying each cell's
    state over (and spilling per window): forced small here, the lists are the same lights
    in the same order and the frame exact."""
    n = 300
    L = np.concatenate([point_crowd(70, radius=12.0), random_shapes(np.random.default_rng(3), n - 70,
                                                              (-14, -1, -34), (14, 7, 6))])
    with Renderer(make_scene(L, size=(48, 32), camera=CAMERA)) as r:
        one = render(r)
        lists_one, cells_one = read_lists(r, one)
        monkeypatch.setattr(limits, "DISPATCH_WINDOW", 128)
        fin = r.frame_input(0, 64)
        if fin.loop_budget is None:
            monkeypatch.setattr(r.limits.__class__, "loop_budget", property(lambda self: 65535))
        many = render(r)
        lists_many, cells_many = read_lists(r, many)
        ref = render_on(r, techniques=["brute"])
    assert len(many.build.own.scans) == -(-many.meta["stats"]["visible_lights"] // 64) > 2
    assert_exact({"brute": ref["brute"], "fptl": many}, "scan windows")
    assert lists_one == lists_many
    assert np.array_equal(cells_one["pruned"], cells_many["pruned"])
    assert np.array_equal(cells_one["coarse"], cells_many["coarse"])
    assert many.meta["stats"]["spilled_lights"] > 0


def test_shading_reads_the_words_not_the_records(gl, monkeypatch):
    """The shading pass binds the lists, spill heads and spill, never the cells' records;
    records overwritten between list building and shading (every flag set, every count
    huge) change nothing it does: the same counters as the frame with its records (spilled
    cells), and, with a short pool (which cells it fails is the GPU's race), exact, every
    pixel evaluating what its cell's words say (its list and spill, or every light)."""
    from app.pipeline.passes import OUT_CELL, HostStep
    rng = np.random.default_rng(11)
    L = np.concatenate([point_crowd(60, radius=9.0), random_shapes(rng, 100, (-14, -1, -34), (14, 7, 6))])
    passes = T.passes
    garbage = lambda got: ({"fptl_cells": np.full(got["fptl_cells"].nbytes // 4, 0xFFFFFFFF, np.uint32)}, [])

    def spoiled(build, opts):
        steps = passes(build, opts)
        last = max(k for k, p in enumerate(steps) if getattr(p, "name", "") == "fptl_lists")
        return steps[:last + 1] + [HostStep("spoil records", ("fptl_cells",), garbage)] + \
            [p for p in steps[last + 1:] if getattr(p, "name", "") != "fptl counts"]

    with Renderer(make_scene(L, size=(64, 48), camera=CAMERA)) as r:
        want = render(r)
        shade = [p for p in passes(want.build, T.resolve_options({}))
                 if getattr(p, "shader", "") == "fptl_shade.comp"]
        assert shade and all("fptl_cells" not in p.reads for p in shade)
        assert want.meta["stats"]["spilled_lights"] > 0 and want.meta["stats"]["pool_full_cells"] == 0
        monkeypatch.setattr(T, "passes", spoiled)
        got = render(r)
        assert (np.ascontiguousarray(r.read("fptl_cells")).view(np.uint32) == 0xFFFFFFFF).all()
        for k in ("evaluated", "contrib_count", "contrib_hash"):
            assert np.array_equal(getattr(got, k), getattr(want, k)), k
        # a short pool: some cells flagged full in their words
        monkeypatch.setattr(fptl, "SPILL_MAX_ENTRIES", 200)
        short = render(r)
        bits, n = short.meta["stats"]["index_bits"], short.meta["stats"]["visible_lights"]
        listed, state = fptl.decode_state(r.read("fptl_lists"), bits)
        heads = r.read("fptl_spill_heads").reshape(-1, len(listed), 2).astype(np.int64)
        cell = r.read(OUT_CELL).astype(np.int64)
        ref = render_on(r, techniques=["brute"])
    assert_exact({"brute": ref["brute"], "fptl": short}, "records spoiled, short pool")
    full = (state & fptl.FLAG_POOL_FULL) != 0
    assert full.any() and not full.all()
    per_cell = np.where(full, n, listed + np.where(state & fptl.FLAG_SPILLED, heads[..., 1].sum(0), 0))
    covered = np.ascontiguousarray(short.depth[::-1]).ravel() > 0
    ev = np.ascontiguousarray(short.evaluated[::-1]).ravel()
    assert np.array_equal(ev[covered], per_cell[cell[covered]])


# ---------------------------------------------------------------------------- variants

def test_variants_are_exact_and_ordered(gl, rng):
    """coarse-only evaluates the coarse lists (>= the fine ones at every pixel); per-cell
    lists are subsets of the tile's (<= at every pixel); every variant exact."""
    scene = shapes_scene(rng, 300, size=(80, 48))
    with Renderer(scene) as r:
        res = {v: render(r, {"fptl_variant": v}) for v in range(4)}
        ref = render_on(r, techniques=["brute"])
        cells_v = render(r, {"fptl_variant": 2})        # per-cell lists: the bytes a tile's cells read
        cell_bytes = expected_shade_bytes(r, cells_v, read_lists(r, cells_v)[0])
    for v, x in res.items():
        assert_exact({"brute": ref["brute"], "fptl": x}, fptl.VARIANTS[v])
        assert x.meta["stats"]["variant"] == fptl.VARIANTS[v]
    fine, coarse, cell, cell_coarse = (res[v].evaluated.astype(np.int64) for v in range(4))
    covered = res[0].depth > 0
    assert (coarse >= fine).all() and (fine >= cell).all() and (cell_coarse >= cell).all()
    assert coarse[covered].sum() > 1.5 * fine[covered].sum()
    t = res[1].build.own.tile_counts
    per_pixel = np.repeat(np.repeat(t["coarse"], 16, 0), 16, 1)[:48, :80]
    assert np.array_equal(res[1].evaluated[covered], per_pixel[covered])
    assert res[2].meta["stats"]["slices"] == fptl.CELL_SLICES
    assert cells_v.meta["stats"]["shade_bytes_per_tile"] == pytest.approx(cell_bytes.mean())
    assert cells_v.meta["stats"]["shade_list_bytes_per_tile"] > res[0].meta["stats"]["shade_list_bytes_per_tile"]
    assert res[2].meta["bytes"]["fptl_lists"] == res[0].meta["bytes"]["fptl_lists"] * fptl.CELL_SLICES


def test_per_type_loops_shade_like_the_one_loop(gl):
    """The chapter's per-type loops (type_loops, the default) and one loop branching on the
    type evaluate the same lights in the same order, the spill included: same counts and
    hashes as brute, same per-pixel work, the same image up to rounding."""
    rng = np.random.default_rng(7)
    L = np.concatenate([point_crowd(40, radius=9.0), random_shapes(rng, 200, (-14, -1, -34), (14, 7, 6))])
    assert len(np.unique(L["type"])) == 4
    with Renderer(make_scene(L, size=(64, 48), camera=CAMERA)) as r:
        loops, one = render(r), render(r, {"type_loops": False})
        ref = render_on(r, techniques=["brute"])
    assert loops.meta["options"]["type_loops"] and not one.meta["options"]["type_loops"]
    for res, want in ((loops, 1), (one, 0)):
        opts = T.resolve_options(res.meta["options"])
        shade = [p for p in T.passes(res.build, opts) if getattr(p, "shader", "") == "fptl_shade.comp"]
        assert shade and all(p.defines["FPTL_TYPE_LOOPS"] == want for p in shade)
    assert loops.meta["stats"]["spilled_lights"] > 0
    for name, x in (("per-type loops", loops), ("one loop", one)):
        assert_exact({"brute": ref["brute"], "fptl": x}, name)
    assert np.array_equal(loops.evaluated, one.evaluated)
    assert np.allclose(loops.image, one.image, rtol=1e-5, atol=1e-7)


def test_gallery_narrow_spots_near_the_floor(gl):
    """The chapter's case: the gallery's narrow spots.  fptl evaluates a small multiple of the
    perfect culler's lights, far fewer than tiled's bounding spheres."""
    from scenes import load_scene
    scene = load_scene("gallery")
    scene.resolution = (240, 136)
    with Renderer(scene) as r:
        res = render_on(r, techniques=["brute", "tiled", "fptl", "perfect"])
    assert_exact(res, "gallery")
    covered = res["brute"].depth > 0
    ev = {n: float(x.evaluated[covered].mean()) for n, x in res.items()}
    assert ev["fptl"] < 3.0 * ev["perfect"] and ev["fptl"] * 5 < ev["tiled"], ev
