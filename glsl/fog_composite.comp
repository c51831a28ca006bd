#version 430
// Fog, pass 3: each pixel's colour through the fog in front of it, colour * T + S, with
// (S, T) the column's integral up to the pixel's depth (sky and anything past the fog's far
// depth: the whole column): the froxels before the pixel's slice whole, then the part of its
// own slice up to the pixel on the pixel's own ray.
#include "generated.glsl"
#include "fog_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;  // w: depth (0 = sky)
layout(std430, binding = B_FROXEL_LIGHT) readonly buffer FroxelLight { vec4 froxel_light[]; };
layout(std430, binding = B_FROXEL_ACCUM) readonly buffer FroxelAccum { vec4 froxel_accum[]; };
layout(std430, binding = B_OUT_COLOR) buffer OutColor { vec4 out_color[]; };

uniform ivec2 u_size;
uniform float u_density;

vec2 segment(float s) {
    float tr = exp(-u_density * s);
    return vec2(u_density * s > 1e-6 ? (1.0 - tr) / u_density : s, tr);
}

// the last t in [0, n) with edge(t) <= x (edges ascending; x below them all: 0)
#define LAST_AT_OR_BELOW(EDGE, N, X, OUT) { \
    uint lo_ = 0u, hi_ = (N); \
    while (hi_ - lo_ > 1u) { uint mid_ = (lo_ + hi_) / 2u; if (EDGE(mid_) <= (X)) lo_ = mid_; else hi_ = mid_; } \
    OUT = lo_; }

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= u_size.x || p.y >= u_size.y) return;
    vec2 c = vec2(p) + 0.5;
    uint i, j;
    LAST_AT_OR_BELOW(edge_x, u_froxels.x, c.x, i);
    LAST_AT_OR_BELOW(edge_y, u_froxels.y, c.y, j);
    float depth = texelFetch(g_position, p, 0).w;
    float far = edge_z(u_froxels.z);
    vec3 S;
    float T;
    if (depth <= 0.0 || depth >= far) {
        vec4 a = froxel_accum[froxel_id(i, j, u_froxels.z - 1u)];
        S = a.rgb;
        T = a.a;
    } else {
        uint k;
        LAST_AT_OR_BELOW(edge_z, u_froxels.z, depth, k);
        vec4 a = k > 0u ? froxel_accum[froxel_id(i, j, k - 1u)] : vec4(0.0, 0.0, 0.0, 1.0);
        vec2 ndc = 2.0 * c / vec2(u_size) - 1.0;
        float stretch = length(vec3(ndc.x * u_tan.x, ndc.y * u_tan.y, 1.0));
        vec2 seg = segment(max(depth - edge_z(k), 0.0) * stretch);
        S = a.rgb + a.a * froxel_light[froxel_id(i, j, k)].rgb * seg.x;
        T = a.a * seg.y;
    }
    uint o = uint(p.y * u_size.x + p.x);
    out_color[o] = vec4(out_color[o].rgb * T + S, out_color[o].a);
}
