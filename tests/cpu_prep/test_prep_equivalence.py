"""The optimized CPU stage against the plain one (tests/cpu_prep/reference_prep.py) on random
frames: every shape, cameras inside and among the lights, lights across the near plane and
behind the eye, odd screens, 1 to 16 slices, exact and bucket sorts, one thread and two.
Everything must be equal bit for bit; the screen rectangles, whose projection has a cheaper
exact form in front of the near plane (cpu_prep.bounds.project_axis), to 1e-6 pixel, and
the binning built from them is compared on the same rectangles."""
from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cpu_prep import frame as cpuframe, grid as gridmod, hybrid, lights as lightsmod, tree
from cpu_prep.arena import Arena
from cpu_prep.camera import frame_camera
from cpu_prep.intrinsics import next_down_f32, next_up_f32
from scenes.model import Camera
from tests.cpu_prep import reference_prep as ref
from tests.helpers import random_shapes, threads_or_skip

FIELDS = ("ids", "type", "center", "bound_radius", "gpu", "bounds", "depth_lo", "depth_hi")


def same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.names:
        a, b = a.view(np.uint8), b.view(np.uint8)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")


def frame(seed: int, n: int, size=(320, 180)):
    """n lights of every shape in a 60 m box, a camera somewhere in it looking anywhere."""
    rng = np.random.default_rng(seed)
    lights = random_shapes(rng, n, (-30, -5, -30), (30, 25, 30), radius=(0.05, 8.0),
                           length=(0.0, 10.0), extent=(0.05, 5.0))
    pos = rng.uniform((-25, 0, -25), (25, 20, 25))
    target = pos + rng.normal(size=3)
    cam = Camera(tuple(pos), tuple(target), (0.0, 1.0, 0.0), float(rng.uniform(20, 120)),
                 float(rng.choice([0.05, 0.25, 1.0])), float(rng.choice([40.0, 200.0])))
    return lights, frame_camera(cam, *size), rng


def check_prepared(pl, want: dict) -> None:
    for f in FIELDS:
        assert same(getattr(pl, f), want[f]), f
    rect, wrect = np.asarray(pl.rect), want["rect"]
    fin = np.isfinite(wrect)
    assert np.array_equal(fin, np.isfinite(rect)) and np.array_equal(rect[~fin], wrect[~fin])
    assert np.all(np.abs(rect[fin] - wrect[fin]) <= 1e-6)


# one and two CPU-stage threads, each its own test (skipped, saying so, where numba has one)
# with half the examples
THREADS = pytest.mark.parametrize("nthreads", [1, 2])


@THREADS
@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 1500), st.sampled_from([0, 0, 64]),
       st.sampled_from([(320, 180), (97, 61), (1, 1)]))
def test_prepare_lights_equals_the_plain_stage(nthreads, seed, n, buckets, size):
    threads_or_skip(nthreads)
    lights, cam, _ = frame(seed, n, size)
    want = ref.prepare(lights, cam, buckets)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(nthreads)
        for arena in (None, Arena()):
            pl = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes(), buckets, arena)
            check_prepared(pl, want)
    finally:
        numba.set_num_threads(before)


@THREADS
@settings(max_examples=12, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 1200), st.sampled_from([8, 16, 48]),
       st.sampled_from([1, 4, 16]))
def test_binning_and_trees_equal_the_plain_stage(nthreads, seed, n, tile, slices):
    threads_or_skip(nthreads)
    lights, cam, rng = frame(seed, n)
    pl = cpuframe.prepare_lights(lights, cam, cpuframe.StageTimes())
    grid = gridmod.make_grid(cam, tile, slices, 150.0, 5.0)
    box = ref.boxes(grid, pl.rect, pl.depth_lo, pl.depth_hi)
    offsets, entries = ref.scatter(grid, box)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(nthreads)
        assert np.array_equal(gridmod.rect_boxes(grid, pl.rect, pl.depth_lo, pl.depth_hi), box)
        arena = Arena()
        for _ in range(2):                       # a fresh arena and a reused one
            o, e = cpuframe.bin_cells(pl, cam, grid, cpuframe.StageTimes(), arena)
            assert same(o, offsets) and same(e, entries)
        o, e = gridmod.scatter(grid, box.astype(np.int32))
        assert same(o, offsets) and same(e, entries)
        for radius_scale, lpl, max_leaves in ((1.0, 6, 64), (0.3, 1, 8), (4.0, 16, 1)):
            want_tree = ref.choose(grid, offsets, entries, pl.depth_lo, pl.depth_hi, 150.0, radius_scale)
            assert same(hybrid.choose_trees(grid, offsets, entries, pl.depth_lo, pl.depth_hi,
                                            150.0, radius_scale), want_tree)
            want = ref.trees(offsets, entries, pl.depth_lo, pl.depth_hi, want_tree, lpl, max_leaves)
            got = hybrid.plan_and_build(grid, offsets, entries, pl.depth_lo, pl.depth_hi, 150.0,
                                        radius_scale, lpl, max_leaves, arena)
            for g, w, name in zip(got, want + (want_tree,), ("ranges", "nodes", "leaves", "is_tree")):
                assert same(g, w), name
            every = rng.random(grid.cells) < 0.5
            want = ref.trees(offsets, entries, pl.depth_lo, pl.depth_hi, every, lpl, max_leaves)
            got = tree.build_trees(offsets, entries, pl.depth_lo, pl.depth_hi, every, lpl, max_leaves)
            for g, w, name in zip(got, want, ("ranges", "nodes", "leaves")):
                assert same(g, w), name
    finally:
        numba.set_num_threads(before)


@pytest.mark.parametrize("scene,lights", [("arena", 8192), ("corridor", 5000), ("gallery", 2000)])
def test_builtin_frames_at_full_hd(scene, lights):
    """The benchmark's frames: 1920x1080, 48-pixel tiles, 16 slices."""
    from scenes import load_scene
    sc = load_scene(scene, lights=lights, seed=1)
    for k in (0, 23):
        cam = frame_camera(sc.camera_at(k, 64), 1920, 1080)
        pl = cpuframe.prepare_lights(sc.lights, cam, cpuframe.StageTimes(), 0, Arena())
        check_prepared(pl, ref.prepare(sc.lights, cam))
        grid = gridmod.make_grid(cam, 48, 16, sc.max_depth, 5.0)
        box = ref.boxes(grid, pl.rect, pl.depth_lo, pl.depth_hi)
        o, e = cpuframe.bin_cells(pl, cam, grid, cpuframe.StageTimes())
        want = np.zeros((grid.tiles_y, grid.tiles_x, grid.slices), np.int64)
        for x0, x1, y0, y1, s0, s1 in box.tolist():      # each box's cells, one slice op a box
            if x0 <= x1 and y0 <= y1 and s0 <= s1:         # (an empty box may end below 0)
                want[y0:y1 + 1, x0:x1 + 1, s0:s1 + 1] += 1
        assert np.array_equal(o[1:] - o[:-1], want.reshape(-1))
        is_tree = ref.choose(grid, o, e, pl.depth_lo, pl.depth_hi, sc.max_depth)
        got = hybrid.plan_and_build(grid, o, e, pl.depth_lo, pl.depth_hi, sc.max_depth, 1.0, 6, 64)
        assert same(got[3], is_tree)
        want = tree.build_trees(o, e, pl.depth_lo, pl.depth_hi, is_tree, 6, 64)
        for g, w in zip(got[:3], want):
            assert same(g, w)


def test_radix_sort_is_stable_and_orders_like_the_values():
    rng = np.random.default_rng(3)
    depth = np.concatenate([rng.uniform(-5, 300, 3000), np.repeat(rng.uniform(0, 50, 20), 40),
                            [0.0, -0.0, 0.0, -1e-30, 1e-30, np.inf, -np.inf, 5e-324, -5e-324],
                            rng.uniform(-5, 300, 500).astype(np.float32).astype(np.float64)])
    rng.shuffle(depth)
    keyed = np.empty(len(depth), np.uint64)
    bits = depth.astype(np.float32).view(np.uint32).astype(np.uint64)
    key = np.where(bits >> 31, ~bits & 0xFFFFFFFF, bits | 0x80000000)
    keyed[:] = (key << 32) | np.arange(len(depth), dtype=np.uint64)
    got = lightsmod.sort_ids(keyed.copy(), depth) & np.uint64(0xFFFFFFFF)
    # the earlier sort (LSD radix, 8-bit digits, on the same keys: -0 just before +0)
    assert np.array_equal(got, lightsmod.depth_order(depth))
    # numpy's stable sort, where -0 and +0 (equal values) do not both occur
    nonzero = depth.astype(np.float32) != 0
    got = lightsmod.sort_ids(keyed[nonzero].copy(), depth[nonzero]) & np.uint64(0xFFFFFFFF)
    assert np.array_equal(np.arange(len(depth))[nonzero][np.argsort(depth[nonzero].astype(np.float32), kind="stable")],
                          got)


def test_next_float_matches_numpy():
    @numba.njit
    def both(x):
        up = np.empty_like(x)
        down = np.empty_like(x)
        for i in range(x.shape[0]):
            up[i], down[i] = next_up_f32(x[i]), next_down_f32(x[i])
        return up, down

    f = np.finfo(np.float32)
    x = np.array([0.0, -0.0, 1.0, -1.0, f.tiny, -f.tiny, f.smallest_subnormal, -f.smallest_subnormal,
                  f.max, -f.max, np.inf, -np.inf, np.nan, 3.5, -7.25, 1e-40, -1e-40], np.float32)
    x = np.concatenate([x, np.random.default_rng(0).standard_normal(1000).astype(np.float32) * 1e3])
    up, down = both(x)
    with np.errstate(over="ignore"):
        assert same(up, np.nextafter(x, np.float32(np.inf)))
        assert same(down, np.nextafter(x, np.float32(-np.inf)))


@pytest.mark.parametrize("slices,near,far", [(16, 5.0, 280.0), (2, 0.5, 10.0), (64, 1.0, 1e4), (1, 5.0, 50.0)])
def test_slice_table_steps_where_listing_4_does(slices, near, far):
    g = gridmod.Grid(960, 540, 48, slices, math.log(near), math.log(far))
    table = gridmod.slice_table(g)
    steps = table[:slices - 1]
    assert np.all(np.isnan(table[slices - 1:])) and np.all(np.diff(steps) > 0)
    around = np.concatenate([steps, np.nextafter(steps, 0), np.nextafter(steps, np.inf),
                             np.geomspace(1e-3, 1e6, 5000), [0.0, -1.0, np.inf, 5e-324]])

    @numba.njit
    def by_table(d, t):
        out = np.empty(d.shape[0], np.int64)
        for i in range(d.shape[0]):
            out[i] = gridmod.slice_from_table(d[i], t)
        return out

    assert np.array_equal(by_table(around, table), g.slice_of(around))


def test_tile_of_is_the_floor_of_the_quotient():
    from fractions import Fraction

    @numba.njit
    def tiles(x, tile):
        out = np.empty(x.shape[0])
        for i in range(x.shape[0]):
            out[i] = gridmod.tile_of(x[i], tile, 1.0 / tile)
        return out

    rng = np.random.default_rng(5)
    for tile in (1, 3, 7, 16, 48, 100, 256):
        k = np.arange(-40, 200, dtype=np.float64) * tile
        x = np.concatenate([k, np.nextafter(k, -np.inf), np.nextafter(k, np.inf),
                            rng.uniform(-1e4, 1e5, 3000), [-5e-324, 5e-324, 0.0, -0.0]])
        got = tiles(x, float(tile))
        assert all(g == math.floor(Fraction(v) / tile) for g, v in zip(got.tolist(), x.tolist()))
        normal = np.abs(x) > 1e-300
        assert np.array_equal(got[normal], np.floor(x[normal] / tile))
    assert tiles(np.array([np.inf, -np.inf]), 48.0).tolist() == [np.inf, -np.inf]


@pytest.mark.parametrize("n", [0, 5, 16, 17, 1500])
def test_cull_chunks_close_their_gaps(n):
    """The cull with threads: each chunk of lights writes its visible ones from its first
    light's index, and _close_cull_gaps moves them together, in scene order; the keys and
    depths are one chunk's (one thread's), every chunk done by this thread here."""
    lights, cam, _ = frame(11 + n, n)
    args = (lights, cam.view_from_world, cam.near, cam.far, 0.7, 0.4)
    one = [np.empty(n, np.uint64), np.empty(n), np.empty(1, np.int64)]
    lightsmod.share.run(lightsmod._cull_chunks, 1, *args, *one)
    k = int(one[2][0])
    assert 0 < k < n or n < 16
    for chunks in (2, 16):
        if chunks > max(n, 1):
            continue
        keyed, depth, visible = np.empty(n, np.uint64), np.empty(n), np.empty(chunks, np.int64)
        claim = np.zeros(3, np.int64)
        lightsmod._cull_chunks(claim, chunks, *args, keyed, depth, visible)
        assert visible.sum() == k
        assert lightsmod._close_cull_gaps(n, keyed, depth, visible) == k
        assert np.array_equal(keyed[:k], one[0][:k]) and np.array_equal(depth[:k], one[1][:k])
