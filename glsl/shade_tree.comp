#version 430
// tree (O'Donnell & Chajdas): one light tree per 2D screen tile, listing 3 traversal.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"
#include "tree.glsl"

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        s.cell = cell_of(s);
        CELLS_ONLY_RETURN(s);
        uvec2 r = ranges[s.cell].offset_count;
        traverse_tree(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated + s.nodes, 2u);
}
