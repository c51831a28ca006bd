#version 450
// raster: each tile's min / max scene depth as float bits, x holding the complement of the
// min so that a zeroed buffer starts both (y 0: no geometry).  Two readers: the stats twin
// (untimed: which lights occlusion alone removed, against a tile depth-bounds test) and
// the cluster rasterizer's MARK / WALK (timed: the slides' "conservative depth from
// prepass"; raster_cluster.frag).  Positive floats order as their bits, so atomicMax on
// the bits is a float max.
//   TILE_DEPTH_GROUP  the tile is a multiple of the 8x8 group, so a group lies in one
//                     tile: reduced in shared memory first, one global atomic pair a group
// define: TILE_DEPTH_GROUP
layout(local_size_x = 8, local_size_y = 8) in;
#include "generated.glsl"
layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;
layout(std430, binding = B_RASTER_TILE_DEPTH) buffer TileDepth { uvec2 tile_depth[]; };
uniform ivec2 u_size;
uniform int u_tile;
uniform ivec2 u_tiles;

#if TILE_DEPTH_GROUP
shared uint near_bits;        // complement of the min's bits
shared uint far_bits;
#endif

// priced: depth
void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    bool inside = all(lessThan(pixel, u_size));
    float d = inside ? texelFetch(g_position, pixel, 0).w : 0.0;
    ivec2 t = pixel / u_tile;
    uint i = uint(t.y * u_tiles.x + t.x);
#if TILE_DEPTH_GROUP
    if (gl_LocalInvocationIndex == 0u) {
        near_bits = 0u;
        far_bits = 0u;
    }
    barrier();
    if (d > 0.0) {
        atomicMax(near_bits, ~floatBitsToUint(d));
        atomicMax(far_bits, floatBitsToUint(d));
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && far_bits != 0u) {
        atomicMax(tile_depth[i].x, near_bits);
        atomicMax(tile_depth[i].y, far_bits);
    }
#else
    if (d <= 0.0) return;
    atomicMax(tile_depth[i].x, ~floatBitsToUint(d));
    atomicMax(tile_depth[i].y, floatBitsToUint(d));
#endif
}
