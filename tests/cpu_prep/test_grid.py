"""Depth slices (listing 4, scale corrected) and the CSR scatter."""
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from cpu_prep import grid as gridmod
from cpu_prep.camera import FrameCamera, perspective


def cam(w=960, h=540, near=0.1):
    return FrameCamera(np.eye(4), perspective(60, w / h, near, 1e4), w, h, near, 1e4, math.tan(math.radians(30)))


def test_slices_are_exponential_and_cover_near_slice_to_max_depth():
    g = gridmod.make_grid(cam(), 48, 16, 500.0, 5.0)
    lo, hi = g.slice_bounds()
    assert lo[0] == 0 and math.isclose(lo[1], 5.0, rel_tol=1e-9)          # slice 0: the near slice
    assert math.isclose(lo[-1], 500.0 / (500 / 5) ** (1 / 15), rel_tol=1e-9) and hi[-1] == np.inf
    ratios = hi[1:-1] / lo[1:-1]
    assert np.allclose(ratios, ratios[0]) and ratios[0] > 1                  # exponential
    # slices 1..15 span [5, 500]: the printed listing would crowd them into slices 1-2
    assert math.isclose(lo[1] * ratios[0] ** 15, 500.0, rel_tol=1e-9)
    d = np.geomspace(5.01, 499, 2000)
    s = g.slice_of(d)
    assert s.min() == 1 and s.max() == 15 and np.all(np.diff(s) >= 0)
    assert len(np.unique(s)) == 15


def test_printed_listing4_would_crowd_slices():
    lmin, lmax, S = math.log(5), math.log(500), 16
    scale = 1.0 / ((lmax - lmin) * (S - 1))          # as printed
    bias = 1.0 - lmin * scale
    assert int(math.log(500) * scale + bias) <= 2    # everything lands in slices 1-2


def test_slice_of_at_or_below_near_is_safe():
    g = gridmod.make_grid(cam(), 48, 16, 500.0, 5.0)
    assert list(g.slice_of(np.array([-5.0, 0.0, 1e-30, 0.1, 1e9]))) == [0, 0, 0, 0, 15]


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31))
def test_scatter_lists_every_light_in_its_box_depth_sorted(seed):
    rng = np.random.default_rng(seed)
    g = gridmod.make_grid(cam(200, 120), 32, 4, 100.0, 5.0)
    n = int(rng.integers(0, 60))
    x0 = rng.uniform(-50, 250, n); y0 = rng.uniform(-50, 150, n)
    rect = (x0, x0 + rng.uniform(0, 100, n), y0, y0 + rng.uniform(0, 80, n))
    dlo = rng.uniform(-5, 120, n)
    boxes = gridmod.cell_boxes(g, rect, dlo, dlo + rng.uniform(0, 50, n))
    offsets, entries = gridmod.scatter(g, boxes)
    tx0, tx1, ty0, ty1, s0, s1 = boxes.T
    expect = [[] for _ in range(g.cells)]
    for i in range(n):
        for s in range(s0[i], s1[i] + 1):
            for ty in range(ty0[i], ty1[i] + 1):
                for tx in range(tx0[i], tx1[i] + 1):
                    expect[(ty * g.tiles_x + tx) * g.slices + s].append(i)
    got = [entries[offsets[c]:offsets[c + 1]].tolist() for c in range(g.cells)]
    assert got == expect       # light order kept: depth-sorted input gives sorted cells


def _random_rects(rng, n, w=960, h=540):
    x = np.sort(rng.uniform(-100, w + 100, (n, 2)), 1)
    y = np.sort(rng.uniform(-100, h + 100, (n, 2)), 1)
    d = np.sort(rng.uniform(0.05, 800.0, (n, 2)), 1)
    rect = np.ascontiguousarray(np.column_stack([x, y]), np.float64)
    rect[::17] = [1.0, 0.0, 1.0, 0.0]                      # empty: nothing of it on screen
    return rect, d[:, 0].astype(np.float32), d[:, 1].astype(np.float32)


def test_box_counts_of_threads_sum_to_one_threads():
    """The boxes' difference-array count with threads: each thread counts its chunks into
    the slot it takes (claim[2]), and the slots' sum is one thread's count."""
    from tests.helpers import with_threads
    rng = np.random.default_rng(7)
    g = gridmod.make_grid(cam(), 48, 16, 500.0, 5.0)
    rect, lo, hi = _random_rects(rng, 5000)
    shape = (g.tiles_y + 1, g.tiles_x + 1, g.slices + 1)
    boxes_ref, diff_ref = np.empty((5000, 6), np.int32), np.zeros(shape, np.int32)
    gridmod._boxes_corners(rect, lo, hi, *gridmod._grid_args(g), boxes_ref, diff_ref)
    assert diff_ref.any()
    # a second thread's call: slot 1, every chunk its own
    parts, boxes = np.zeros((2,) + shape, np.int32), np.empty((5000, 6), np.int32)
    claim = np.array([0, 0, 1], np.int64)
    gridmod._boxes_corners_chunks(claim, 16, rect, lo, hi, *gridmod._grid_args(g), boxes, parts)
    assert claim.tolist() == [17, 16, 2]
    assert not parts[0].any() and np.array_equal(parts[1], diff_ref)
    assert np.array_equal(boxes, boxes_ref)
    for _ in range(10):         # two threads: whichever thread counted which chunk
        diff = np.zeros(shape, np.int32)
        with_threads(2, lambda: gridmod._count_boxes(g, rect, lo, hi, boxes, diff, None))
        assert np.array_equal(diff, diff_ref) and np.array_equal(boxes, boxes_ref)
