#version 430
// The support of sample-tree: tree.glsl's exact traversal of the pixel's tile tree, every
// light of every leaf its depth test reaches (those a descent reaches with p > 0)
// evaluated, their affecting set's count and hash stored (glsl/sampling.glsl).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"
#include "sampling.glsl"

void main() {
#if defined(CELLS_ONLY) && CELLS_ONLY
    return;                       // a modelled frame: no light loop runs, no support to count
#endif
    PixelState s = load_pixel();
    if (s.shading) {
        uvec2 r = ranges[cell_of(s)].offset_count;
        traverse_tree(s, r.x, r.y);
    }
    store_support(s);
}
