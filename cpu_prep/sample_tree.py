"""The light trees' sampling bounds (app/techniques/sample_tree): what a stochastic descent
of a tile's tree (cpu_prep.tree, O'Donnell & Chajdas 2017) reads besides the nodes, in the
manner of Stochastic Lightcuts (Yuksel 2019) with a cut of one node, the root.

    sample_nodes[node]: SAMPLE_NODE, beside nodes[node] (the same index)
        box_lo_power  xyz the least view-space light centre of the node's subtree, w its power
        box_hi        xyz the greatest centre, w the longest reach of its lights
        pieces        x first, y count of its depth pieces (zw unused)
    depth_pieces[piece] = (lo, hi): the union of the subtree's leaf depth intervals as
                          disjoint closed intervals sorted by lo

A subtree's power is the sum of its lights' brightest channel of colour x intensity (the
bound cpu_prep.sampling uses per list entry): over the distance d from a pixel to the box of
the subtree's light centres, power / (d^2 + 1) bounds the sum of its lights' I / (d_i^2 + 1)
(the light model's falloff under an attenuation window of at most 1), and where d passes
the subtree's longest reach (light_reach) no light of it can reach the pixel: importance 0
(the descent's defensive share still keeps p > 0 there).  Yuksel's importance also bounds
the orientation; this one keeps the distance alone.

Depth pieces: tree.glsl's traversal reaches a leaf exactly when the pixel's depth lies in
the leaf's [min_depth, max_depth] (every ancestor's interval is the min/max of its children's,
so it holds the leaf's).  A node's own interval is only their hull: a depth between two
leaves' intervals hits it and none of its leaves, and a descent that entered it would end
with no light.  So the descent asks of a child whether the depth lies in one of its pieces,
compared as node_hit compares (depth >= lo && depth <= hi on the same float32 bounds): it
enters exactly the subtrees that hold a leaf the traversal reaches, and never ends empty.
"""
from __future__ import annotations

import numba
import numpy as np

from scenes.model import LIGHT_TYPES

from .layouts import NODE_BITS, NODE_FIRST_LIGHT, NODE_MAX_DEPTH, NODE_MIN_DEPTH, NODE_WORDS
from .limits import NODE_COUNT_BITS
from . import sampling
from .sampling import DEFENSIVE

SAMPLE_NODE = np.dtype([
    ("box_lo_power", np.float32, 4),
    ("box_hi", np.float32, 4),
    ("pieces", np.uint32, 4),
])
assert SAMPLE_NODE.itemsize == 48

# Share of the uniform choice between two enterable children (defensive mixture, as
# cpu_prep.sampling.DEFENSIVE for a list): every light the traversal reaches keeps p > 0,
# also under a child of zero power, and no child's weight 1/p passes 2 / NODE_DEFENSIVE.
NODE_DEFENSIVE = 0.02
# A leaf of more lights draws one uniformly (p = 1/n) instead of by their bounds: the bound
# passes read every light of the leaf twice a sample, and leaves grow past lights_per_leaf
# only where a tile's lights pass max_leaves x lights_per_leaf (or 65,535 a leaf); this
# keeps a sample's loops short under a driver's loop limit (docs/platform.md): 64 samples of
# two passes over 256 lights are 32,768 iterations of the 65,535.
LEAF_SCAN = 256


def light_reach(gpu_lights: np.ndarray) -> np.ndarray:
    """(N,) float32: how far from its centre each light can affect a point, as the shader's
    light_reach computes it: a box its half diagonal (its radius is ignored), any other
    shape its radius plus half its capsule segment (0 but for capsules)."""
    box = gpu_lights["id_type"][:, 1] == LIGHT_TYPES.index("box")
    ext = gpu_lights["extent_length"]
    return np.where(box, np.sqrt((ext[:, :3].astype(np.float64) ** 2).sum(1)),
                    gpu_lights["pos_radius"][:, 3] + 0.5 * ext[:, 3].astype(np.float64)).astype(np.float32)


def light_power(gpu_lights: np.ndarray) -> np.ndarray:
    """(N,) float64: each light's brightest channel of colour x intensity (at least 0)."""
    return np.maximum(gpu_lights["color_cos_inner"][:, :3].max(1).astype(np.float64), 0.0)


@numba.njit(cache=True, nogil=True)
def _bounds(nf, nu, entries, centre, power, reach, lo, hi, pw, far, p_off, p_lo, p_hi, p_n, depth):
    """Every node, children before parents (depth-first order reversed): its centre box,
    power, longest reach and depth pieces (in scratch p_lo/p_hi at p_off[node], p_n[node] of them); then
    parents before children: each node's level below its tree's root."""
    n = nf.shape[0]
    count_mask = (1 << NODE_COUNT_BITS) - 1
    for i in range(n - 1, -1, -1):
        bits = np.int64(nu[i, NODE_BITS])
        o = p_off[i]
        if bits & 1:
            first, cnt = np.int64(nu[i, NODE_FIRST_LIGHT]), (bits >> 1) & count_mask
            s, f = 0.0, np.float32(0.0)
            for a in range(3):
                lo[i, a], hi[i, a] = np.inf, -np.inf
            for e in range(first, first + cnt):
                j = entries[e]
                s += power[j]
                f = max(f, reach[j])
                for a in range(3):
                    lo[i, a] = min(lo[i, a], centre[j, a])
                    hi[i, a] = max(hi[i, a], centre[j, a])
            pw[i], far[i] = s, f
            a_lo, a_hi = nf[i, NODE_MIN_DEPTH], nf[i, NODE_MAX_DEPTH]
            p_n[i] = 0
            if a_lo <= a_hi:                  # an empty leaf (lo inf, hi -inf) has none
                p_lo[o], p_hi[o], p_n[i] = a_lo, a_hi, 1
            continue
        left = i + 1
        right = left + (np.int64(nu[left, NODE_BITS]) >> (1 + NODE_COUNT_BITS))
        pw[i] = pw[left] + pw[right]
        far[i] = max(far[left], far[right])
        for a in range(3):
            lo[i, a] = min(lo[left, a], lo[right, a])
            hi[i, a] = max(hi[left, a], hi[right, a])
        p_n[i] = _merge(p_lo, p_hi, p_off[left], p_n[left], p_off[right], p_n[right], o)
    for i in range(n):                    # a root's level is 0; children follow their parent
        bits = np.int64(nu[i, NODE_BITS])
        if not bits & 1:
            left = i + 1
            right = left + (np.int64(nu[left, NODE_BITS]) >> (1 + NODE_COUNT_BITS))
            depth[left] = depth[i] + 1
            depth[right] = depth[i] + 1


@numba.njit(inline="always")
def _merge(p_lo, p_hi, a, na, b, nb, out):
    """Two sorted lists of disjoint closed intervals merged at `out`, touching or overlapping
    ones joined (their union holds the same floats); returns the count written."""
    i, j, m = 0, 0, 0
    while i < na or j < nb:
        if j >= nb or (i < na and p_lo[a + i] <= p_lo[b + j]):
            x, y = p_lo[a + i], p_hi[a + i]
            i += 1
        else:
            x, y = p_lo[b + j], p_hi[b + j]
            j += 1
        if m > 0 and x <= p_hi[out + m - 1]:
            p_hi[out + m - 1] = max(p_hi[out + m - 1], y)
        else:
            p_lo[out + m], p_hi[out + m] = x, y
            m += 1
    return m


def sample_nodes(nodes: np.ndarray, entries: np.ndarray, gpu_lights: np.ndarray):
    """(sample_nodes SAMPLE_NODE, depth_pieces (P, 2) float32, levels (nodes,) int64) of a
    frame's trees (module docstring); levels: each node's depth below its root."""
    n = len(nodes)
    flat = nodes.view(np.uint32).reshape(n, NODE_WORDS)
    nf, nu = flat.view(np.float32), flat
    skip = (nu[:, NODE_BITS].astype(np.int64) >> (1 + NODE_COUNT_BITS))
    room = (skip + 1) // 2                    # a full binary subtree's leaves: pieces at most
    p_off = np.concatenate([[0], np.cumsum(room)[:-1]]).astype(np.int64) if n else np.zeros(0, np.int64)
    total = int(room.sum())
    p_lo, p_hi = np.empty(total, np.float32), np.empty(total, np.float32)
    p_n = np.zeros(n, np.int64)
    lo, hi = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
    pw, levels, far = np.zeros(n), np.zeros(n, np.int64), np.zeros(n, np.float32)
    centre = np.ascontiguousarray(gpu_lights["pos_radius"][:, :3])
    _bounds(nf, nu, np.asarray(entries, np.int64), centre, light_power(gpu_lights),
            light_reach(gpu_lights), lo, hi, pw, far,
            p_off, p_lo, p_hi, p_n, levels)
    out = np.zeros(n, SAMPLE_NODE)
    out["box_lo_power"][:, :3], out["box_lo_power"][:, 3] = lo, pw
    out["box_hi"][:, :3], out["box_hi"][:, 3] = hi, far
    first = np.concatenate([[0], np.cumsum(p_n)[:-1]]) if n else np.zeros(0, np.int64)
    out["pieces"][:, 0], out["pieces"][:, 1] = first, p_n
    keep = np.repeat(p_off, p_n) + (np.arange(int(p_n.sum())) - np.repeat(first, p_n))
    pieces = np.stack([p_lo[keep], p_hi[keep]], 1).astype(np.float32)
    return out, pieces.reshape(-1, 2), levels


# ---- the GPU's draws again, for the cost model's replay (sample_tree.comp) ---------------
# float32 throughout, in the shader's order of operations; a comparison the GPU's rounding
# (a fused multiply-add, say) decides the other way moves one draw of ~2^-24 odds.

_F = np.float32


def next_unit(state: np.ndarray, draw: np.ndarray) -> np.ndarray:
    """next_unit() for the lanes `draw` (bool): their state advanced in place; u (float32)."""
    new, bits = sampling.next_random(state)
    state[draw] = new[draw]
    return (bits >> np.uint32(8)).astype(_F) * _F(1.0 / 16777216.0)


def enterable(sample: np.ndarray, pieces: np.ndarray, node: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """node_enterable(): the depth in one of the node's pieces (numpy's search is the same
    test: the last piece whose lo <= depth, then depth <= its hi)."""
    first = sample["pieces"][node, 0].astype(np.int64)
    count = sample["pieces"][node, 1].astype(np.int64)
    lo, hi = first.copy(), first + count
    while (lo < hi).any():
        act = lo < hi
        mid = (lo + hi) >> 1
        up = act & (depth >= pieces[np.where(act, mid, 0), 0])
        lo, hi = np.where(up, mid + 1, lo), np.where(act & ~up, mid, hi)
    k = np.maximum(lo - 1, 0)
    return (lo > first) & (depth <= pieces[k, 1] if len(pieces) else False)


def _within(d2, reach):
    return d2 <= reach * reach * _F(1.0001)


def _dot(v):
    return v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2]


def importance(sample: np.ndarray, node: np.ndarray, P: np.ndarray) -> np.ndarray:
    """node_importance() per lane (float32)."""
    b = sample[node]
    gap = np.maximum(b["box_lo_power"][:, :3] - P, _F(0)) + np.maximum(P - b["box_hi"][:, :3], _F(0))
    d2 = _dot(gap)
    return np.where(_within(d2, b["box_hi"][:, 3]), b["box_lo_power"][:, 3] / (d2 + _F(1)), _F(0))


def light_columns(gpu_lights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre xyz, reach, power) of every light as light_bound() reads them (float32): the
    reach and power are per light, so they are made once, not once a lane."""
    pr = gpu_lights["pos_radius"]
    c = gpu_lights["color_cos_inner"]
    box = gpu_lights["id_type"][:, 1] == LIGHT_TYPES.index("box")
    ext = gpu_lights["extent_length"]
    reach = np.where(box, np.sqrt(_dot(ext[:, :3])), pr[:, 3] + _F(0.5) * ext[:, 3])
    power = np.maximum(np.maximum(c[:, 0], c[:, 1]), np.maximum(c[:, 2], _F(0)))
    return np.ascontiguousarray(pr[:, :3]), reach, power


def light_bounds(columns, slot: np.ndarray, P: np.ndarray) -> np.ndarray:
    """light_bound() of the lights `slot` at the lanes' positions P (float32); `columns`:
    light_columns() of the lights."""
    pos, reach, power = columns
    d2 = _dot(P - pos[slot])
    return np.where(_within(d2, reach[slot]), power[slot] / (d2 + _F(1)), _F(0))


def descend(nodes, sample, pieces, base, P, depth, state):
    """descend_to_leaf() for lanes at the roots `base` (each enterable): (the leaf reached,
    per level (lanes still descending, left child, right child)); `state` advanced."""
    bits = nodes["bits"].astype(np.int64)
    is_leaf, skip = (bits & 1) == 1, bits >> (1 + NODE_COUNT_BITS)
    d = _F(NODE_DEFENSIVE)
    keep, even = _F(1) - d, _F(0.5) * d
    i, levels = np.asarray(base, np.int64).copy(), []
    while True:
        act = ~is_leaf[i]
        if not act.any():
            return i, levels
        left = np.where(act, i + 1, i)
        right = np.where(act, left + skip[left], i)
        el = act & enterable(sample, pieces, left, depth)
        er = act & enterable(sample, pieces, right, depth)
        wl, wr = importance(sample, left, P), importance(sample, right, P)
        total = wl + wr
        share = np.where(total > 0, wl / np.where(total > 0, total, _F(1)), _F(0.5))
        both = el & er
        u = next_unit(state, both)
        go_left = np.where(both, u < keep * share + even, el)
        levels.append((act, left, right))
        i = np.where(act, np.where(go_left, left, right), i)


def draw_leaf(nodes, entries, gpu_lights, leaf, P, state):
    """draw_leaf_light() for lanes at the leaves `leaf`: the entry each draws."""
    first = nodes["first_light"][leaf].astype(np.int64)
    count = (nodes["bits"][leaf].astype(np.int64) >> 1) & ((1 << NODE_COUNT_BITS) - 1)
    draw = count > 1
    u = next_unit(state, draw)
    scan = draw & (count <= LEAF_SCAN)
    longest = int(count[scan].max(initial=0))
    # each position's bound, once, at the lanes whose leaf has it (the sum and the search
    # read no other): the same float32 operations on the same values as the shader's
    columns = light_columns(gpu_lights)
    bounds = []
    for k in range(longest):
        at = np.nonzero(scan & (k < count))[0]
        b = np.zeros(len(leaf), _F)
        b[at] = light_bounds(columns, entries[first[at] + k], P[at])
        bounds.append(b)
    total = np.zeros(len(leaf), _F)
    for k in range(longest):                     # the sum in the shader's order
        m = scan & (k < count)
        total = np.where(m, total + bounds[k], total)
    uniform = np.where(total > 0, _F(DEFENSIVE), _F(1))
    by_uniform = u < uniform
    e = first + np.minimum((u / uniform * count.astype(_F)).astype(np.int64), count - 1)
    t = (u - uniform) / (_F(1) - np.where(by_uniform, _F(0), uniform)) * total
    chosen, found = first + count - 1, np.zeros(len(leaf), bool)
    for k in range(longest):
        m = scan & ~by_uniform & (k < count) & ~found
        w = bounds[k]
        hit = m & (t < w)
        chosen, found = np.where(hit, first + k, chosen), found | hit
        t = np.where(m & ~hit, t - w, t)
    return np.where(draw, np.where(by_uniform, e, chosen), first)
