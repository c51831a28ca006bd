"""The top-down tree build (cpu_prep.tree_topdown, `tree_build` 1): the numba build equals a
plain recursive Python one bit for bit (one thread and two, tree and hybrid); its trees are
depth-first with skip counts = subtree sizes, within the bottom-up tree's leaf budget and
the 16-bit light count; listing 3 over them finds exactly the covering lights; its splits
follow the cost (a gap between two clusters, no split where nothing culls), and it evaluates
fewer lights per pixel than the bottom-up tree where the lights are spread."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cpu_prep import grid as gridmod, hybrid, layouts, limits, tree, tree_topdown
from cpu_prep.camera import frame_camera
from scenes.model import Camera
from tests.cpu_prep.tree_walk import traverse
from tests.helpers import with_threads

TOPDOWN = tree.BUILD_TOPDOWN


def reference_topdown(offsets, entries, depth_lo, depth_hi, leaves, lights_per_leaf,
                      node_cost=tree_topdown.NODE_COST):
    """cpu_prep.tree_topdown's build, plainly: recursive, float64 costs, every k tried.
    leaves: each cell's leaf budget (the bottom-up tree's leaf count).  Returns (ranges,
    nodes) as tree.build_trees does."""
    M = limits.NODE_MAX_LIGHTS
    need = lambda m: max(1, -(-m // M))
    out = []

    def bounds(a, b):
        ids = entries[a:b]
        return np.float32(depth_lo[ids].min()), np.float32(depth_hi[ids].max())

    def build(a, m, budget, lo, hi):
        me = len(out)
        out.append([lo, hi, a, None])
        k = 0
        if budget > 1 and (m > lights_per_leaf or m > M):
            best, bd = np.inf, m + 1
            for j in range(1, m):
                if m > M and need(j) + need(m - j) > budget:
                    continue
                llo, lhi = bounds(a, a + j)
                rlo, rhi = bounds(a + j, a + m)
                cost = (float(lhi) - float(llo)) * j + (float(rhi) - float(rlo)) * (m - j)
                if cost < best or (cost == best and abs(2 * j - m) < bd):
                    best, bd, k = cost, abs(2 * j - m), j
            ext = float(hi) - float(lo)
            if k and m <= M and not best + 2.0 * node_cost * ext < m * ext:
                k = 0
        if not k:
            out[me][3] = (1, m, 1)
            return 1
        bl = min(max((budget * k + m // 2) // m, need(k)), budget - need(m - k))
        size = 1 + build(a, k, bl, *bounds(a, a + k))
        size += build(a + k, m - k, budget - bl, *bounds(a + k, a + m))
        out[me][3] = (0, 0, size)
        return size

    cells = len(offsets) - 1
    ranges = np.zeros(cells, layouts.CELL_RANGE)
    for c in range(cells):
        o, n = int(offsets[c]), int(offsets[c + 1] - offsets[c])
        start = len(out)
        if n:
            if leaves[c] == 1:
                out.append([*bounds(o, o + n), o, (1, n, 1)])
            else:
                build(o, n, int(leaves[c]), *bounds(o, o + n))
        ranges["offset_count"][c] = (start, len(out) - start)
    raw = np.zeros((len(out), layouts.NODE_WORDS), np.float32)
    for q, (lo, hi, first, bits) in enumerate(out):
        raw[q, layouts.NODE_MIN_DEPTH], raw[q, layouts.NODE_MAX_DEPTH] = lo, hi
        raw.view(np.uint32)[q, layouts.NODE_FIRST_LIGHT] = first
        raw.view(np.uint32)[q, layouts.NODE_BITS] = layouts.node_bits(*bits)
    return ranges, raw.view(layouts.TREE_NODE).reshape(-1)


def same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.array_equal(a.view(np.uint8), b.view(np.uint8))


def random_cells(rng, cells=6, n_lights=400, most=300, spread=100.0):
    counts = rng.integers(0, most, cells)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    center = np.sort(rng.uniform(0, spread, n_lights))
    rad = rng.uniform(0.01, 10, n_lights)
    lo, hi = (center - rad).astype(np.float32), (center + rad).astype(np.float32)
    entries = np.concatenate([np.sort(rng.choice(n_lights, c, replace=False))
                              for c in counts]).astype(np.uint32)
    return offsets, entries, lo, hi


def check_shape(ranges, nodes, offsets, entries, budget):
    """Depth-first, skip = subtree size, leaves partition the cell's entries in order,
    within the leaf budget and the 16-bit count."""
    for c in range(len(offsets) - 1):
        base, count = (int(v) for v in ranges["offset_count"][c])
        if offsets[c + 1] == offsets[c]:
            assert count == 0
            continue
        t = nodes[base:base + count]
        leaf, cnt, skip = layouts.unpack_node_bits(t["bits"])
        assert skip[0] == count and count == 2 * leaf.sum() - 1 and leaf.sum() <= budget[c]
        assert cnt[leaf].max() <= limits.NODE_MAX_LIGHTS and (cnt[~leaf] == 0).all()
        # the leaves in memory order are the cell's entries in order
        firsts, sizes = t["first_light"][leaf].astype(np.int64), cnt[leaf].astype(np.int64)
        assert firsts[0] == offsets[c] and (firsts[1:] == firsts[:-1] + sizes[:-1]).all()
        assert firsts[-1] + sizes[-1] == offsets[c + 1]

        def walk(p):                       # pre-order: the left child next, the right after it
            if leaf[p]:
                assert skip[p] == 1
                return 1
            left = walk(p + 1)
            right = walk(p + 1 + left)
            assert skip[p] == 1 + left + right
            assert t["first_light"][p] == t["first_light"][p + 1]
            for q in (p + 1, p + 1 + left):   # a node's bounds hold its children's
                assert t["min_depth"][p] <= t["min_depth"][q] and t["max_depth"][q] <= t["max_depth"][p]
            return skip[p]

        assert walk(0) == count


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("threads", [1, 2])
def test_topdown_equals_the_plain_build(seed, threads):
    rng = np.random.default_rng(seed)
    offsets, entries, lo, hi = random_cells(rng)
    for lpl, max_leaves in ((6, 64), (1, 8), (16, 1), (3, 16)):
        is_tree = rng.random(len(offsets) - 1) < 0.7
        got = with_threads(threads, lambda: tree.build_trees(offsets, entries, lo, hi, is_tree, lpl,
                                                             max_leaves, build=TOPDOWN))
        budget = tree.leaves_per_cell(np.diff(offsets), is_tree, lpl, max_leaves)
        want = reference_topdown(offsets, entries, lo, hi, budget, lpl)
        assert same(got[0], want[0]) and same(got[1], want[1]), (lpl, max_leaves)
        assert (got[2] == (want[0]["offset_count"][:, 1].astype(np.int64) + 1) // 2).all()
        check_shape(got[0], got[1], offsets, entries, budget)


@pytest.mark.parametrize("threads", [1, 2])
def test_hybrid_plan_with_topdown_equals_choose_then_build(threads):
    """The hybrid's one-pass plan (one thread) and choose_trees + build_trees (two) give the
    same bits with the top-down build, and the tree cells are the top-down trees."""
    cam = frame_camera(Camera((0.0, 2.0, 8.0), (0.0, 1.0, -20.0), (0.0, 1.0, 0.0), 60.0, 0.1, 300.0),
                       160, 96)
    grid = gridmod.make_grid(cam, 16, 8, 150.0, 5.0)
    rng = np.random.default_rng(5)
    cells = grid.cells
    counts = rng.integers(0, 60, cells)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    n = 2000
    c = np.sort(rng.uniform(0, 150, n))
    r = rng.uniform(0.05, 20, n)
    lo, hi = (c - r).astype(np.float32), (c + r).astype(np.float32)
    entries = np.concatenate([np.sort(rng.choice(n, k, replace=False)) for k in counts]).astype(np.uint32)
    for radius_scale in (1.0, 4.0):
        got = with_threads(threads, lambda: hybrid.plan_and_build(
            grid, offsets, entries, lo, hi, 150.0, radius_scale, 6, 64, build=TOPDOWN))
        is_tree = hybrid.choose_trees(grid, offsets, entries, lo, hi, 150.0, radius_scale)
        assert same(got[3], is_tree)
        want = with_threads(1, lambda: tree.build_trees(offsets, entries, lo, hi, is_tree, 6, 64,
                                                        build=TOPDOWN))
        for g, w in zip(got[:3], want):
            assert same(g, w)
        budget = tree.leaves_per_cell(counts, is_tree, 6, 64)
        ref = reference_topdown(offsets, entries, lo, hi, budget, 6)
        assert same(got[0], ref[0]) and same(got[1], ref[1])


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 12), st.sampled_from([1, 2, 8, 64]))
def test_traversal_of_topdown_trees_finds_exactly_the_covering_lights(seed, lpl, max_leaves):
    rng = np.random.default_rng(seed)
    offsets, entries, lo, hi = random_cells(rng, cells=5, n_lights=300, most=200)
    is_tree = rng.random(5) < 0.8
    ranges, nodes, leaves = tree.build_trees(offsets, entries, lo, hi, is_tree, lpl, max_leaves,
                                             build=TOPDOWN)
    bottom = tree.build_trees(offsets, entries, lo, hi, is_tree, lpl, max_leaves)
    check_shape(ranges, nodes, offsets, entries, bottom[2])
    for c in range(5):
        base, count = ranges["offset_count"][c]
        assert count <= bottom[0]["offset_count"][c, 1]
        for depth in rng.uniform(-5, 110, 20).astype(np.float32):
            hit, visited = traverse(nodes, base, count, depth)
            got = set(entries[hit].tolist())
            want = {int(e) for e in entries[offsets[c]:offsets[c + 1]] if lo[e] <= depth <= hi[e]}
            assert want <= got and len(hit) == len(set(hit)) and visited <= count


def test_split_falls_in_the_gap_and_overlap_stays_a_leaf():
    """Two clusters of small lights 100 m apart: the root splits between them (a balanced
    split in an extent-blind build would too here, so the clusters are unequal); lights that
    all span one range stay one leaf (a split would cull nothing and cost two visits)."""
    a = np.linspace(10, 12, 30)
    b = np.linspace(110, 112, 10)
    c = np.concatenate([a, b])
    lo, hi = (c - 0.5).astype(np.float32), (c + 0.5).astype(np.float32)
    n = len(c)
    ranges, nodes, leaves = tree.build_trees(np.array([0, n]), np.arange(n, dtype=np.uint32), lo, hi,
                                             np.array([True]), 6, 64, build=TOPDOWN)
    left = nodes[1]
    assert left["max_depth"] < 50 and layouts.unpack_node_bits(nodes["bits"][0])[2] == len(nodes)
    right = nodes[int(layouts.unpack_node_bits(left["bits"])[2]) + 1]
    assert right["min_depth"] > 50 and right["first_light"] == 30
    # every light spans [0, 100]: nothing to cull, one leaf
    lo, hi = np.zeros(50, np.float32), np.full(50, 100.0, np.float32)
    ranges, nodes, leaves = tree.build_trees(np.array([0, 50]), np.arange(50, dtype=np.uint32), lo, hi,
                                             np.array([True]), 6, 64, build=TOPDOWN)
    assert len(nodes) == 1 and leaves[0] == 1


def test_a_list_past_16_bits_splits_within_its_budget():
    """70,000 lights in one cell with a one-leaf cap: the budget is the two leaves the
    16-bit count needs, and each leaf holds at most 65,535 lights."""
    n = 70_000
    c = np.linspace(0, 1, n)
    lo, hi = (c - 0.5).astype(np.float32), (c + 0.5).astype(np.float32)
    for is_tree, max_leaves in ((False, 64), (True, 1)):
        ranges, nodes, leaves = tree.build_trees(np.array([0, n]), np.arange(n, dtype=np.uint32),
                                                 lo, hi, np.array([is_tree]), 6, max_leaves,
                                                 build=TOPDOWN)
        leaf, cnt, skip = layouts.unpack_node_bits(nodes["bits"])
        assert len(nodes) == 3 and leaves[0] == 2 and cnt[leaf].max() <= limits.NODE_MAX_LIGHTS
        hit, _ = traverse(nodes, 0, 3, 0.5)
        assert sorted(hit) == list(range(n))


def expected_lights(nodes, base, count):
    """Lights a pixel evaluates in a tree, its depth uniform over the root's extent."""
    t = nodes[base:base + count]
    leaf, cnt, _ = layouts.unpack_node_bits(t["bits"])
    ext = (t["max_depth"].astype(np.float64) - t["min_depth"]).clip(0)
    return float((cnt[leaf] * ext[leaf]).sum() / max(ext[0], 1e-30))


def test_topdown_evaluates_fewer_lights_on_spread_lights():
    """Small lights spread in depth (arena-like tiles): the top-down trees' expected lights
    per pixel (its own cost model) are below the bottom-up trees' for every seed, with no
    more nodes."""
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        offsets, entries, lo, hi = random_cells(rng, cells=4, n_lights=2000, most=1500, spread=500.0)
        every = np.ones(4, bool)
        bu = tree.build_trees(offsets, entries, lo, hi, every, 6, 64)
        td = tree.build_trees(offsets, entries, lo, hi, every, 6, 64, build=TOPDOWN)
        e_bu = sum(expected_lights(bu[1], *bu[0]["offset_count"][c]) for c in range(4) if offsets[c + 1] > offsets[c])
        e_td = sum(expected_lights(td[1], *td[0]["offset_count"][c]) for c in range(4) if offsets[c + 1] > offsets[c])
        assert e_td < e_bu and len(td[1]) <= len(bu[1]), (seed, e_td, e_bu)


def test_unknown_build_is_an_error():
    with pytest.raises(ValueError):
        tree.build_trees(np.array([0, 0]), np.zeros(0, np.uint32), np.zeros(0, np.float32),
                         np.zeros(0, np.float32), np.array([True]), 6, 64, build=2)
