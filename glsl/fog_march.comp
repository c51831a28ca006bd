#version 430
// Fog, pass 2: along each froxel column (its centre ray), the scattering and transmittance
// integrated from the near plane to each froxel's far edge.  A homogeneous medium of
// extinction sigma_t = u_density with a froxel's in-scatter L constant over it: a segment of
// length s adds T * L * (1 - exp(-sigma_t s)) / sigma_t and multiplies T by exp(-sigma_t s).
#include "generated.glsl"
#include "fog_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = B_FROXEL_LIGHT) readonly buffer FroxelLight { vec4 froxel_light[]; };
layout(std430, binding = B_FROXEL_ACCUM) writeonly buffer FroxelAccum { vec4 froxel_accum[]; };

uniform float u_density;

// what a segment of length s adds per unit in-scatter, and its transmittance
vec2 segment(float s) {
    float tr = exp(-u_density * s);
    return vec2(u_density * s > 1e-6 ? (1.0 - tr) / u_density : s, tr);
}

void main() {
    uvec2 g = gl_GlobalInvocationID.xy;
    if (g.x >= u_froxels.x || g.y >= u_froxels.y) return;
    float u = 0.5 * (edge_u(g.x) + edge_u(g.x + 1u));
    float v = 0.5 * (edge_v(g.y) + edge_v(g.y + 1u));
    float stretch = length(vec3(u * u_tan.x, v * u_tan.y, 1.0));   // ray length per unit depth
    vec3 S = vec3(0.0);
    float T = 1.0;
    for (uint k = 0u; k < u_froxels.z; ++k) {
        uint id = froxel_id(g.x, g.y, k);
        vec2 seg = segment((edge_z(k + 1u) - edge_z(k)) * stretch);
        S += T * froxel_light[id].rgb * seg.x;
        T *= seg.y;
        froxel_accum[id] = vec4(S, T);
    }
}
