// Light tree traversal, tree paper listing 3: depth-first nodes, stackless, forward only.
// Node bits (listing 1, cpu_prep.layouts.pack_node_bits): isLeaf:1 | lightCount:16 | skipCount:15.
// Any tree laid out depth-first (pre-order) with skip count = subtree size walks correctly:
// the bottom-up build's complete trees and the top-down build's unbalanced ones
// (cpu_prep.tree_topdown); a hit goes to i + 1, a miss past the subtree, never backwards.
// define: SHARED_TREE_NODES

layout(std430, binding = B_NODES) readonly buffer Nodes { TreeNode nodes[]; };

bool node_is_leaf(uint bits) { return (bits & 1u) != 0u; }
uint node_light_count(uint bits) { return (bits >> 1) & ((1u << NODE_COUNT_BITS) - 1u); }
uint node_skip(uint bits) { return bits >> (1u + NODE_COUNT_BITS); }
bool node_hit(TreeNode n, float depth) { return depth >= n.min_depth && depth <= n.max_depth; }

void visit_node(inout PixelState s, TreeNode n, inout uint i) {
    if (first_window()) s.nodes++;      // every window walks the same nodes: count them once
    if (node_hit(n, cell_depth(s))) {   // the tree's depths: its camera's (glsl/cells.glsl)
        if (node_is_leaf(n.bits)) evaluate_list(s, n.first_light, node_light_count(n.bits));
        i++;
    } else {
        i += node_skip(n.bits);
    }
}

void traverse_tree(inout PixelState s, uint base, uint count) {
    uint i = 0u;
    // priced: node minus: evaluate_list
    while (i < count) visit_node(s, nodes[base + i], i);
}

// The tree loaded into shared memory when the whole group traverses one tree (paper 3.4).
shared TreeNode s_tree[SHARED_TREE_NODES];

void traverse_shared_tree(inout PixelState s, uint count) {
    uint i = 0u;
    // priced: lds_node minus: evaluate_list
    while (i < count) visit_node(s, s_tree[i], i);
}

// Called by every invocation of the group (it holds a barrier).
void load_shared_tree(uint base, uint count) {
    // priced: load
    for (uint i = gl_LocalInvocationIndex; i < count; i += 64u) s_tree[i] = nodes[base + i];
    barrier();
}
