"""Light trees: depth-first tables, skip counts, O(n) sizes, bit-width fallbacks, and a
Python run of listing 3 that finds exactly the lights whose depth range holds a depth."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cpu_prep import limits, tree
from tests.cpu_prep.tree_walk import traverse




@pytest.mark.parametrize("leaves", [1, 2, 4, 8, 64])
def test_depth_first_tables(leaves):
    order, skip, is_leaf = tree.depth_first_tables(leaves)
    assert sorted(order) == list(range(2 * leaves - 1))
    assert skip[0] == 2 * leaves - 1 and is_leaf.sum() == leaves
    # a node's skip lands right after its subtree: on the next sibling or an ancestor's
    for p in range(len(order)):
        assert p + skip[p] <= len(order)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 12), st.sampled_from([1, 2, 8, 64]))
def test_traversal_finds_exactly_the_covering_lights(seed, lpl, max_leaves):
    rng = np.random.default_rng(seed)
    cells = 5
    counts = rng.integers(0, 200, cells)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    n_lights = 300
    center = np.sort(rng.uniform(0, 100, n_lights))
    rad = rng.uniform(0, 10, n_lights)
    lo, hi = (center - rad).astype(np.float32), (center + rad).astype(np.float32)
    entries = np.concatenate([np.sort(rng.choice(n_lights, c, replace=False)) for c in counts]).astype(np.uint32)
    is_tree = rng.random(cells) < 0.7
    ranges, nodes, leaves = tree.build_trees(offsets, entries, lo, hi, is_tree, lpl, max_leaves)
    for c in range(cells):
        base, count = ranges["offset_count"][c]
        assert count == (2 * leaves[c] - 1 if counts[c] else 0)
        for depth in rng.uniform(-5, 110, 20).astype(np.float32):
            hit, _ = traverse(nodes, base, count, depth)
            got = set(entries[hit].tolist())
            want = {int(e) for e in entries[offsets[c]:offsets[c + 1]] if lo[e] <= depth <= hi[e]}
            assert want <= got                             # exact: no covering light missed
            assert len(hit) == len(set(hit))               # each light at most once


def test_tree_size_is_linear_with_leaf_cap():
    counts = np.array([6, 7, 60, 384, 385, 5000])
    leaves = tree.leaves_per_cell(counts, np.ones(6, bool), 6, 64)
    assert list(leaves) == [1, 2, 16, 64, 64, 64]


def test_list_past_16_bits_becomes_two_leaves():
    n = limits.NODE_MAX_LIGHTS + 10
    offsets = np.array([0, n])
    entries = np.arange(n, dtype=np.uint32)
    lo = np.zeros(n, np.float32); hi = np.ones(n, np.float32)
    ranges, nodes, leaves = tree.build_trees(offsets, entries, lo, hi, np.array([False]), 6, 64)
    assert leaves[0] == 2 and len(nodes) == 3
    hit, _ = traverse(nodes, 0, 3, 0.5)
    assert sorted(hit) == list(range(n))


def test_skip_count_overflow_is_an_error():
    with pytest.raises(limits.LimitError):
        tree.leaves_per_cell(np.array([10 ** 6]), np.array([True]), 1, 1 << 15)


def test_visits_fewer_nodes_than_lights_for_spread_lights():
    n = 384
    c = np.linspace(0, 1000, n)
    lo, hi = (c - 1).astype(np.float32), (c + 1).astype(np.float32)
    ranges, nodes, _ = tree.build_trees(np.array([0, n]), np.arange(n, dtype=np.uint32), lo, hi,
                                        np.array([True]), 6, 64)
    hit, visited = traverse(nodes, 0, len(nodes), 500.0)
    assert len(nodes) == 127 and visited <= 2 * 7 + 1 and len(hit) <= 12
