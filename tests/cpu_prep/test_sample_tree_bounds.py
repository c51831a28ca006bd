"""cpu_prep.sample_tree: each node's power, light-centre box, reach and depth pieces equal their
brute-force values over its subtree, and a depth lies in a node's pieces exactly where the
tree's traversal (listing 3) reaches a leaf of that subtree: a descent that enters a node
always finds a light, and enters every subtree the traversal reaches."""
import numpy as np
import pytest

from cpu_prep import layouts, sample_tree as st, tree
from tests.cpu_prep.tree_walk import traverse


def _frame(seed, lpl, max_leaves, build, cells=4, n_lights=240):
    """Random depth-sorted lights binned into cells, their trees and GPU rows."""
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 150, cells)
    counts[0] = 120                                  # one tree that surely has levels
    offsets = np.concatenate([[0], np.cumsum(counts)])
    centre = np.sort(rng.uniform(0, 100, n_lights))
    # sparse and dense lights: leaf intervals with gaps between them, and overlapping ones
    rad = np.where(rng.random(n_lights) < 0.5, rng.uniform(0, 0.3, n_lights), rng.uniform(0, 8, n_lights))
    lo, hi = (centre - rad).astype(np.float32), (centre + rad).astype(np.float32)
    entries = np.concatenate([np.sort(rng.choice(n_lights, c, replace=False)) for c in counts]).astype(np.uint32)
    ranges, nodes, _ = tree.build_trees(offsets, entries, lo, hi, np.ones(cells, bool), lpl,
                                        max_leaves, build=build)
    gpu = np.zeros(n_lights, layouts.GPU_LIGHT)
    gpu["pos_radius"][:, :3] = rng.normal(0, 10, (n_lights, 3))
    gpu["pos_radius"][:, 2] = -centre
    gpu["color_cos_inner"][:, :3] = rng.uniform(0, 5, (n_lights, 3))
    gpu["color_cos_inner"][rng.random(n_lights) < 0.1, :3] = 0.0     # dark lights: power 0
    return rng, ranges, nodes, entries, gpu


def _subtree_entries(nodes, i):
    """The entries of the leaves in node i's subtree (depth-first: nodes i .. i + skip - 1)."""
    leaf, cnt, skip = layouts.unpack_node_bits(nodes["bits"])
    out, leaves = [], []
    for j in range(i, i + int(skip[i])):
        if leaf[j]:
            leaves.append(j)
            out += range(int(nodes["first_light"][j]), int(nodes["first_light"][j] + cnt[j]))
    return out, leaves


CASES = [(s, lpl, L, b) for s, lpl, L in [(1, 6, 64), (2, 1, 8), (3, 3, 16)]
         for b in (tree.BUILD_BOTTOMUP, tree.BUILD_TOPDOWN)]


@pytest.mark.parametrize("seed,lpl,max_leaves,build", CASES)
def test_node_powers_boxes_and_reach_are_the_sums_and_bounds_of_their_subtrees(seed, lpl, max_leaves, build):
    rng, _, nodes, entries, gpu = _frame(seed, lpl, max_leaves, build)
    gpu["pos_radius"][:, 3] = rng.uniform(0.1, 5, len(gpu))
    capsule, box = rng.random(len(gpu)) < 0.2, rng.random(len(gpu)) < 0.2
    gpu["id_type"][capsule, 1], gpu["extent_length"][capsule, 3] = 2, 3.0
    gpu["id_type"][box, 1], gpu["extent_length"][box, :3] = 3, [1.0, 2.0, 2.0]
    reach = np.where(box, 3.0, gpu["pos_radius"][:, 3] + np.where(capsule & ~box, 1.5, 0.0))
    assert np.allclose(st.light_reach(gpu), reach, rtol=1e-6)
    got, _, _ = st.sample_nodes(nodes, entries, gpu)
    power = st.light_power(gpu)
    centre = gpu["pos_radius"][:, :3]
    assert (power == 0).any() and len(nodes) > 50
    for i in range(len(nodes)):
        ids = entries[_subtree_entries(nodes, i)[0]]
        assert np.isclose(got["box_lo_power"][i, 3], power[ids].sum(), rtol=1e-6, atol=0), i
        if len(ids):
            assert np.array_equal(got["box_lo_power"][i, :3], centre[ids].min(0)), i
            assert np.array_equal(got["box_hi"][i, :3], centre[ids].max(0)), i
            assert got["box_hi"][i, 3] == st.light_reach(gpu)[ids].max(), i
    assert np.allclose(power, gpu["color_cos_inner"][:, :3].max(1))


@pytest.mark.parametrize("seed,lpl,max_leaves,build", CASES)
def test_a_depth_is_in_a_nodes_pieces_exactly_where_the_traversal_reaches_its_leaves(
        seed, lpl, max_leaves, build):
    rng, ranges, nodes, entries, gpu = _frame(seed, lpl, max_leaves, build)
    got, pieces, levels = st.sample_nodes(nodes, entries, gpu)
    first, count = got["pieces"][:, 0].astype(np.int64), got["pieces"][:, 1].astype(np.int64)
    for i in range(len(nodes)):                       # sorted, disjoint, none empty
        p = pieces[first[i]:first[i] + count[i]]
        assert (p[:, 0] <= p[:, 1]).all() and (p[1:, 0] > p[:-1, 1]).all(), i
    gaps = 0
    for base, n in ranges["offset_count"].astype(np.int64):
        assert n == 0 or levels[base] == 0
        # depths at the pieces' ends, between them and random: every edge of the test
        ends = pieces[np.concatenate([np.arange(first[k], first[k] + count[k]) for k in range(base, base + n)]
                                     or [np.zeros(0, np.int64)])].ravel()
        depths = np.concatenate([ends, np.nextafter(ends, np.float32(np.inf)),
                                 np.nextafter(ends, np.float32(-np.inf)),
                                 rng.uniform(-5, 110, 40).astype(np.float32)]).astype(np.float32)
        for z in depths:
            reached, _ = traverse(nodes, base, n, z)
            reached = set(reached)
            for i in range(base, base + n):
                p = pieces[first[i]:first[i] + count[i]]
                inside = bool(((p[:, 0] <= z) & (z <= p[:, 1])).any())
                want = bool(reached & set(_subtree_entries(nodes, i)[0]))
                assert inside == want, (i, z)
                hull = nodes["min_depth"][i] <= z <= nodes["max_depth"][i]
                gaps += hull and not inside
    assert gaps > 0, "no depth fell between leaves: the pieces' case is untested"


def test_a_frame_without_trees_has_no_bounds():
    got, pieces, levels = st.sample_nodes(np.zeros(0, layouts.TREE_NODE), np.zeros(0, np.uint32),
                                          np.zeros(0, layouts.GPU_LIGHT))
    assert len(got) == len(levels) == 0 and pieces.shape == (0, 2)
