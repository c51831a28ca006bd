#version 430
// tiled (Andersson 2009, Harada 2012): one 16x16 workgroup per screen tile reduces the
// tile's min/max depth from the G-buffer, then tests every visible light's bounding sphere
// against the tile's frustum (four side planes through the eye, widened by a pixel, and
// the depth range).  Lists are allocated from one global pool; a tile whose list does not
// fit is flagged (count TILE_OVERFLOW) and shades every light, so no light is ever dropped.
#include "generated.glsl"
#include "tiled_lists.glsl"         // TILE_OVERFLOW, from app/techniques/tiled.py
layout(local_size_x = 16, local_size_y = 16) in;

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;
layout(std430, binding = B_BOUNDS) readonly buffer Bounds { GpuBound bounds[]; };
layout(std430, binding = B_RANGES) writeonly buffer TileRanges { CellRange tile_ranges[]; };
layout(std430, binding = B_ENTRIES) writeonly buffer TileEntries { uint tile_entries[]; };
layout(std430, binding = B_COUNTER) coherent buffer Counter { uint pool_used; };

uniform ivec2 u_size;
uniform int u_tile;
uniform uint u_light_count;
uniform uint u_capacity;      // entries in the pool
uniform vec2 u_tan_half;      // tan of the half field of view, x and y

shared uint s_min, s_max, s_count, s_base;
shared uint s_mask[8];        // one bit per invocation: its light of this chunk is in the tile

// Signed distance from the side plane through the eye at ndc coordinate `n` along one axis
// (positive inside when `sign` = +1 for the low edge, -1 for the high edge).
float side_distance(float a, float z, float n, float t, float sign) {
    float k = n * t;
    return sign * (a + k * z) * inversesqrt(1.0 + k * k);
}

bool sphere_in_tile(vec4 b, vec4 ndc, float dmin, float dmax) {
    vec3 c = b.xyz;
    // float32 margin: the plane distances below round at ~1e-7 of |c|
    float r = b.w * 1.0001 + 1e-5 * length(c) + 1e-7;
    float d = -c.z;
    return d - r <= dmax && d + r >= dmin
        && side_distance(c.x, c.z, ndc.x, u_tan_half.x, 1.0) >= -r
        && side_distance(c.x, c.z, ndc.z, u_tan_half.x, -1.0) >= -r
        && side_distance(c.y, c.z, ndc.y, u_tan_half.y, 1.0) >= -r
        && side_distance(c.y, c.z, ndc.w, u_tan_half.y, -1.0) >= -r;
}

void main() {
    uint lid = gl_LocalInvocationIndex;
    ivec2 origin = ivec2(gl_WorkGroupID.xy) * u_tile;
    uint tile = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (lid == 0u) { s_min = 0x7F800000u; s_max = 0u; s_count = 0u; }
    barrier();
    // Depths are positive floats, whose bit patterns order like the values.
    for (int y = int(gl_LocalInvocationID.y); y < u_tile; y += 16)
        // priced: depth
        for (int x = int(gl_LocalInvocationID.x); x < u_tile; x += 16) {
            ivec2 p = origin + ivec2(x, y);
            if (all(lessThan(p, u_size))) {
                float depth = texelFetch(g_position, p, 0).w;
                if (depth > 0.0) {
                    atomicMin(s_min, floatBitsToUint(depth));
                    atomicMax(s_max, floatBitsToUint(depth));
                }
            }
        }
    barrier();
    float dmin = uintBitsToFloat(s_min), dmax = uintBitsToFloat(s_max);
    bool empty = s_min > s_max;
    // The tile's pixel rectangle, one pixel wider on each side, in NDC.
    vec2 lo = vec2(origin - 1) / vec2(u_size) * 2.0 - 1.0;
    vec2 hi = vec2(min(origin + u_tile, u_size) + 1) / vec2(u_size) * 2.0 - 1.0;
    vec4 ndc = vec4(lo, hi);

    // priced: cull_test
    for (uint i = lid; i < u_light_count && !empty; i += 256u)
        if (sphere_in_tile(bounds[i].center_radius, ndc, dmin, dmax)) atomicAdd(s_count, 1u);
    barrier();
    if (lid == 0u) {
        s_base = s_count > 0u ? atomicAdd(pool_used, s_count) : 0u;
        bool overflow = s_base + s_count > u_capacity || s_base + s_count < s_base;
        tile_ranges[tile].offset_count = overflow ? uvec2(0u, TILE_OVERFLOW) : uvec2(s_base, s_count);
        if (overflow) s_count = TILE_OVERFLOW;
    }
    barrier();
    bool write = s_count != TILE_OVERFLOW && !empty;
    // Fill in light order (= depth order, like every other technique's lists), so the list
    // and the image's summation order do not depend on atomic scheduling: per chunk of 256
    // lights, each hit's slot is the number of hits of lower invocations.
    uint next = s_base;
    uint chunks = write ? (u_light_count + 255u) / 256u : 0u;
    for (uint c = 0u; c < chunks; ++c) {
        if (lid < 8u) s_mask[lid] = 0u;
        barrier();
        uint i = c * 256u + lid;
        bool hit = i < u_light_count && sphere_in_tile(bounds[i].center_radius, ndc, dmin, dmax);
        if (hit) atomicOr(s_mask[lid >> 5], 1u << (lid & 31u));
        barrier();
        uint below = bitCount(s_mask[lid >> 5] & ((1u << (lid & 31u)) - 1u));
        uint total = 0u;
        for (uint w = 0u; w < 8u; ++w) {
            uint n = bitCount(s_mask[w]);
            if (w < (lid >> 5)) below += n;
            total += n;
        }
        if (hit) tile_entries[next + below] = i;
        next += total;
        barrier();
    }
}
