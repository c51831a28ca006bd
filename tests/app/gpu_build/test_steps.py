"""The GPU build's scan and radix sort (app/gpu_build/steps.py) against numpy: a scan past
one group's chunk of block sums (its carry loop), a sort of many blocks with ties (stable:
ties keep their input order, as np.argsort(kind="stable"))."""
from __future__ import annotations

import numpy as np

from app.gpu_build import steps
from app.pipeline.renderer import Renderer
from tests.helpers import make_scene, random_lights


def _renderer():
    return Renderer(make_scene(random_lights(np.random.default_rng(0), 4, (-1, 0, -5), (1, 1, -4)),
                               size=(8, 8)))


def test_scan_of_more_words_than_one_chunk_of_block_sums(gl):
    n = steps.SCAN_BLOCK * steps.SCAN_BLOCK + 1234          # 1,025 chunks of block sums
    src = np.random.default_rng(1).integers(0, 4, n).astype(np.uint32)
    with _renderer() as r:
        r.upload("src", src)
        r.upload("counters", np.zeros(4, np.uint32))
        r.run(steps.scan("scan", "src", "dst", n, "counters", total_word=2))
        dst, counters = r.read("dst"), r.read("counters")
    assert np.array_equal(dst, np.concatenate([[0], np.cumsum(src)[:-1]]).astype(np.uint32))
    assert counters[2] == src.sum()


def test_sort_is_stable_over_many_blocks_and_the_counted_pairs_only(gl):
    n, count = 5000, 4321                                    # 20 blocks; pairs past count ignored
    rng = np.random.default_rng(2)
    keys = rng.integers(0, 40, n).astype(np.uint32) * np.uint32(0x01010101)   # every digit, ties
    with _renderer() as r:
        r.upload("k", keys)
        r.upload("v", np.arange(n, dtype=np.uint32))
        r.upload("counters", np.array([count, 0, 0, 0], np.uint32))
        r.run(steps.sort("sort", "k", "v", "ko", "vo", n, 32, "counters", 0))
        ko, vo = r.read("ko")[:count], r.read("vo")[:count]
    order = np.argsort(keys[:count], kind="stable")
    assert np.array_equal(vo, order) and np.array_equal(ko, keys[:count][order])
