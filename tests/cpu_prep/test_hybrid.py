"""Listing 2: lists where lights overlap most of the cell's depth, trees where they do not."""
import math

import numpy as np

from cpu_prep import grid as gridmod, hybrid
from cpu_prep.camera import FrameCamera, perspective


def one_tile_grid():
    cam = FrameCamera(np.eye(4), perspective(60, 1, 0.1, 1000), 48, 48, 0.1, 1000, math.tan(math.radians(30)))
    return gridmod.make_grid(cam, 48, 4, 500.0, 5.0)


def test_large_overlapping_lights_make_a_list_small_ones_a_tree():
    g = one_tile_grid()
    lo, hi = g.slice_bounds()
    s = 2                                          # one slice, both cases
    cell_lo, cell_hi = lo[s], hi[s]
    n = 20
    big_lo = np.full(n, cell_lo - 1.0, np.float32)
    big_hi = np.full(n, cell_hi + 1.0, np.float32)
    centers = np.linspace(cell_lo, cell_hi, n)
    small_lo, small_hi = (centers - 0.01).astype(np.float32), (centers + 0.01).astype(np.float32)
    for dlo, dhi, want in ((big_lo, big_hi, False), (small_lo, small_hi, True)):
        offsets = np.zeros(g.cells + 1, np.int64)
        offsets[s + 1:] = n
        is_tree = hybrid.choose_trees(g, offsets, np.arange(n, dtype=np.uint32), dlo, dhi, 500.0)
        assert is_tree[s] == want and is_tree.sum() == int(want)


def test_radius_scale_moves_the_threshold():
    g = one_tile_grid()
    lo, hi = g.slice_bounds()
    s, n = 2, 10
    half = 0.5 * (hi[s] - lo[s])
    # each light covers 60% of the cell: a list at scale 1, a tree at scale 2
    dlo = np.full(n, lo[s], np.float32)
    dhi = np.full(n, lo[s] + 1.2 * half, np.float32)
    offsets = np.zeros(g.cells + 1, np.int64)
    offsets[s + 1:] = n
    e = np.arange(n, dtype=np.uint32)
    assert not hybrid.choose_trees(g, offsets, e, dlo, dhi, 500.0, 1.0)[s]
    assert hybrid.choose_trees(g, offsets, e, dlo, dhi, 500.0, 2.0)[s]
