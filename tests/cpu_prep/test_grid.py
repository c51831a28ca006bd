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
