// The cell of the 2.5D grid (or 2D tile when u_slices == 1) a pixel reads: one function for
// the shading passes and the feature-variant classification (glsl/variant_classify.comp),
// so that a tile is classified by the very cells its pixels shade from.
uniform ivec2 u_tiles;        // tiles in x and y
uniform int u_tile;           // tile size in pixels
#include "slices.glsl"

// priced: cell
uint cell_of(PixelState s) {
    ivec2 t = s.pixel / u_tile;
    uint sl = u_slices > 1 ? slice_of(s.depth) : 0u;
    return (uint(t.y) * uint(u_tiles.x) + uint(t.x)) * uint(u_slices) + sl;   // tile-major (cpu_prep.grid)
}
