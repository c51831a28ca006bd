// The cell of the 2.5D grid (or 2D tile when u_slices == 1) a pixel reads: one function for
// the shading passes and the feature-variant classification (glsl/variant_classify.comp),
// so that a tile is classified by the very cells its pixels shade from.
uniform ivec2 u_tiles;        // tiles in x and y
uniform int u_tile;           // tile size in pixels
#include "slices.glsl"

// define: STEREO_UNION
#if STEREO_UNION
// Stereo's union way (app/stereo.py): the grid is the union camera's, which shares this
// eye's orientation and projection, so the pixel's view-space position maps to the union
// camera's by a translation; its cell is where that point projects in the union camera.
uniform vec3 u_union_offset;  // this eye's origin in the union camera's view space
uniform vec2 u_union_tan;     // the union camera's tan(fov_x / 2), tan(fov_y / 2)

ivec2 union_pixel(vec3 Pu) {
    vec2 ndc = Pu.xy / (-Pu.z * u_union_tan);
    ivec2 p = ivec2(floor((ndc * 0.5 + 0.5) * vec2(u_size)));
    return clamp(p, ivec2(0), u_size - 1);
}
#endif

// The pixel's linear depth in the structure's camera (the union camera's with STEREO_UNION):
// what its depth ranges (slices, tree nodes) are compared with.
float cell_depth(PixelState s) {
#if STEREO_UNION
    return -(s.P.z + u_union_offset.z);
#else
    return s.depth;
#endif
}

// priced: cell
uint cell_of(PixelState s) {
#if STEREO_UNION
    vec3 Pu = s.P + u_union_offset;
    ivec2 t = union_pixel(Pu) / u_tile;
    uint sl = u_slices > 1 ? slice_of(cell_depth(s)) : 0u;
#else
    ivec2 t = s.pixel / u_tile;
    uint sl = u_slices > 1 ? slice_of(s.depth) : 0u;
#endif
    return (uint(t.y) * uint(u_tiles.x) + uint(t.x)) * uint(u_slices) + sl;   // tile-major (cpu_prep.grid)
}
