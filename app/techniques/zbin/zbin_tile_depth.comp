#version 430
// zbin (Drobot 2017): the tiles culled against depth, as the slides' are (their tiles are
// rasterized light proxies tested against the depth buffer; the CPU's hold every light whose
// screen rectangle meets the tile).  One 8x8 group per bit-array tile: the tile's min / max
// scene depth from the G-buffer (as tiled's tile_cull), then each set bit kept only where its
// light's conservative depth range [lo, hi] (cpu_prep: rounded outwards) meets [min, max]; a
// tile with no geometry keeps nothing.  Exact: a light that affects a pixel of the tile has
// that pixel's depth inside its range, and the pixel's depth inside the tile's.
#include "generated.glsl"
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;
layout(std430, binding = B_TILE_BITS) readonly buffer TileBits { uint tile_bits[]; };
layout(std430, binding = B_LIGHT_DEPTH) readonly buffer LightDepth { vec2 light_depth[]; };
layout(std430, binding = B_ZBIN_BITS) writeonly buffer Culled { uint zbin_bits[]; };

uniform ivec2 u_size;
uniform int u_tile;           // bit-array tile, pixels
uniform uint u_words;         // words per tile

shared uint s_min, s_max;

void main() {
    uint lid = gl_LocalInvocationIndex;
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * u_tile;
    uint tile = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (lid == 0u) { s_min = 0x7F800000u; s_max = 0u; }
    barrier();
    // depths are positive floats, whose bit patterns order like the values
    for (int y = int(gl_LocalInvocationID.y); y < u_tile; y += 8)
        // priced: depth
        for (int x = int(gl_LocalInvocationID.x); x < u_tile; x += 8) {
            ivec2 p = origin + ivec2(x, y);
            if (all(lessThan(p, u_size))) {
                float d = texelFetch(g_position, p, 0).w;
                if (d > 0.0) {
                    atomicMin(s_min, floatBitsToUint(d));
                    atomicMax(s_max, floatBitsToUint(d));
                }
            }
        }
    barrier();
    bool empty = s_min > s_max;
    float dmin = uintBitsToFloat(s_min), dmax = uintBitsToFloat(s_max);
    for (uint w = lid; w < u_words; w += 64u) {
        uint bits = empty ? 0u : tile_bits[tile * u_words + w];
        uint keep = 0u;
        // priced: cull_test
        for (uint m = bits; m != 0u; m &= m - 1u) {
            uint b = uint(findLSB(m));
            vec2 r = light_depth[w * 32u + b];
            if (r.x <= dmax && r.y >= dmin) keep |= 1u << b;
        }
        zbin_bits[tile * u_words + w] = keep;
    }
}
