#version 430
// sample-tree: S stochastic descents of the pixel's tile tree (Stochastic Lightcuts, Yuksel
// 2019, with a cut of one node, the root), each shading the light it reaches, weighted
// 1 / (S p) with p the product of its choices (app/techniques/sample_tree/__init__.py).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"
#include "sampling.glsl"
#include "sample_tree.glsl"

layout(std430, binding = B_SAMPLE_NODES) readonly buffer SampleNodes { SampleNode sample_nodes[]; };
layout(std430, binding = B_DEPTH_PIECES) readonly buffer DepthPieces { vec2 depth_pieces[]; };

// Whether `depth` lies in one of node i's depth pieces (cpu_prep.sample_tree: sorted,
// disjoint), compared as node_hit compares: the subtree holds a leaf the traversal reaches.
bool node_enterable(uint i, float depth) {
    uvec2 r = sample_nodes[i].pieces.xy;
    uint lo = r.x, hi = r.x + r.y;           // the last piece with its lo <= depth
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (depth >= depth_pieces[mid].x) lo = mid + 1u; else hi = mid;
    }
    return lo > r.x && depth <= depth_pieces[lo - 1u].y;
}

// Whether a squared distance d2 is within `reach` (a relative margin: a miss here only
// leaves the defensive share, never p = 0).
bool within_reach(float d2, float reach) { return d2 <= reach * reach * 1.0001; }

// power / (d^2 + 1), d the distance from P to the node's box of light centres; 0 past the
// longest reach of its lights (cpu_prep.sample_tree).
float node_importance(uint i, vec3 P) {
    SampleNode b = sample_nodes[i];
    vec3 gap = max(b.box_lo_power.xyz - P, 0.0) + max(P - b.box_hi.xyz, 0.0);
    float d2 = dot(gap, gap);
    return within_reach(d2, b.box_hi.w) ? b.box_lo_power.w / (d2 + 1.0) : 0.0;
}

// How far from its centre L can affect a point (cpu_prep.sample_tree.light_reach).
float light_reach(GpuLight L) {
    return L.id_type.y == LIGHT_BOX ? length(L.extent_length.xyz)
                                    : L.pos_radius.w + 0.5 * L.extent_length.w;
}

// I / (d^2 + 1): the light's brightest channel over its centre's distance; 0 past its reach.
float light_bound(PixelState s, GpuLight L) {
    vec3 d = s.P - L.pos_radius.xyz;
    vec3 c = L.color_cos_inner.rgb;
    float d2 = dot(d, d);
    return within_reach(d2, light_reach(L)) ? max(max(c.r, c.g), max(c.b, 0.0)) / (d2 + 1.0) : 0.0;
}

// From the root (enterable) down to a leaf; p *= each choice's probability.
uint descend_to_leaf(inout PixelState s, uint base, inout uint stream, inout float p) {
    uint i = base;
    s.nodes++;
    TreeNode n = nodes[i];
    // priced: node
    while (!node_is_leaf(n.bits)) {
        uint l = i + 1u;
        TreeNode nl = nodes[l];
        uint r = l + node_skip(nl.bits);
        s.nodes += 2u;
        bool el = node_enterable(l, s.depth), er = node_enterable(r, s.depth);
        float q = el ? 1.0 : 0.0;                      // probability of the left child
        if (el && er) {
            float wl = node_importance(l, s.P), wr = node_importance(r, s.P);
            float share = wl + wr > 0.0 ? wl / (wl + wr) : 0.5;
            q = (1.0 - SAMPLE_NODE_DEFENSIVE) * share + 0.5 * SAMPLE_NODE_DEFENSIVE;
            bool left = next_unit(stream) < q;
            p *= left ? q : 1.0 - q;
            q = left ? 1.0 : 0.0;
        }
        i = q > 0.0 ? l : r;
        n = q > 0.0 ? nl : nodes[r];
    }
    return i;
}

// One light of the leaf: by I / (d^2 + 1) mixed with the uniform choice (SAMPLE_LEAF_SCAN
// lights at most; a larger leaf draws uniformly).  Returns its entry; p *= its probability.
uint draw_leaf_light(PixelState s, TreeNode n, inout uint stream, inout float p) {
    uint first = n.first_light, count = node_light_count(n.bits);
    if (count == 1u) return first;
    float u = next_unit(stream);
    float total = 0.0;
    if (count <= SAMPLE_LEAF_SCAN) {
        for (uint k = first; k < first + count; ++k) total += light_bound(s, LIST_LIGHT(k));
    }
    float uniform_share = total > 0.0 ? SAMPLE_LEAF_DEFENSIVE : 1.0;
    uint e;
    if (u < uniform_share) {
        e = first + min(uint(u / uniform_share * float(count)), count - 1u);
    } else {
        float t = (u - uniform_share) / (1.0 - uniform_share) * total;
        e = first + count - 1u;
        for (uint k = first; k < first + count; ++k) {
            float w = light_bound(s, LIST_LIGHT(k));
            if (t < w) { e = k; break; }
            t -= w;
        }
    }
    float mine = total > 0.0 ? light_bound(s, LIST_LIGHT(e)) / total : 0.0;
    p *= (1.0 - uniform_share) * mine + uniform_share / float(count);
    return e;
}

void main() {
    PixelState s = load_pixel();
    s.cell = s.shading ? cell_of(s) : 0u;
    CELLS_ONLY_RETURN(s);
    uvec2 r = s.shading ? ranges[s.cell].offset_count : uvec2(0u);
    if (r.y > 0u) s.nodes++;                 // the root's pieces, read once a pixel
    if (r.y > 0u && node_enterable(r.x, s.depth)) {
        uint stream = pixel_stream(s);
        vec3 sum = vec3(0.0);
        // priced: light
        for (uint k = 0u; k < u_samples; ++k) {
            float p = 1.0;
            uint leaf = descend_to_leaf(s, r.x, stream, p);
            uint e = draw_leaf_light(s, nodes[leaf], stream, p);
            GpuLight L = LIST_LIGHT(e);
            sum += weighted(light_contribution(s, L, L.id_type.y), p);
        }
        s.radiance = sum / float(u_samples);
    }
    store_estimate(s);
    write_wave_stats(s.evaluated + s.nodes, CASE_TREE);
}
