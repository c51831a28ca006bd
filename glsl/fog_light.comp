#version 430
// Fog, pass 1: each froxel's in-scattered radiance, from its light set (the lights that meet
// it: cpu_prep/froxels.py), at FROXEL_SAMPLES points inside it (1: its centre; 8: its octants'
// centres, a box filter of the froxel), each light decided by the one "affects" test of every
// technique (features.glsl) and weighted by the Henyey-Greenstein phase of the angle between
// the light's travel and the ray back to the eye.  Also the froxel's light-set figures (the
// dump's froxel_count, froxel_hash), counted from the list this pass loops over.
#include "generated.glsl"
#include "features.glsl"
#include "fog_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// define: FROXEL_SAMPLES
#ifndef FROXEL_SAMPLES
#define FROXEL_SAMPLES 1
#endif

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = B_FROXEL_RANGES) readonly buffer FroxelRanges { CellRange froxel_ranges[]; };
layout(std430, binding = B_FROXEL_ENTRIES) readonly buffer FroxelEntries { uint froxel_entries[]; };
layout(std430, binding = B_FROXEL_LIGHT) writeonly buffer FroxelLight { vec4 froxel_light[]; };
layout(std430, binding = B_FROXEL_STATS) writeonly buffer FroxelStats { uvec2 froxel_stats[]; };

uniform vec3 u_scattering;    // albedo * density (1/m)
uniform float u_anisotropy;   // Henyey-Greenstein g

const float PI = 3.14159265358979;

// Dump contract's mix (pixel.glsl's mix_hash).
uint froxel_mix(uint x) {
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}

float phase_hg(float cos_theta) {
    float g = u_anisotropy;
    float den = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * den * sqrt(den));
}

// The direction towards the light that its radiance is taken along at a medium point (the
// "normal" that makes the surface term 1): the light's own l.
vec3 towards_light(GpuLight L, vec3 d, float d2, uint type) {
#if HAS_BOX
    if (type == LIGHT_BOX) return -L.dir_cos_outer.xyz;
#endif
#if HAS_CAPSULE
    if (type == LIGHT_CAPSULE) {
        vec3 q = capsule_offset(L, d);
        return -q * inversesqrt(max(dot(q, q), 1e-30));
    }
#endif
    return -d * inversesqrt(max(d2, 1e-30));
}

vec3 inscatter_at(vec3 P, uint first, uint count) {
    vec3 sum = vec3(0.0);
    float inv_p = inversesqrt(max(dot(P, P), 1e-30));
    for (uint e = 0u; e < count; ++e) {
        GpuLight L = lights[froxel_entries[first + e]];
        uint type = L.id_type.y;
        precise vec3 d = P - L.pos_radius.xyz;
        precise float d2 = dot(d, d);
        if (!light_affects_as(L, d, d2, type)) continue;
        vec3 N = towards_light(L, d, d2, type);
        vec3 l;
        vec3 arriving = light_radiance_as(L, d, d2, N, l, type);
        // the light travels along -l, then back to the eye along -P: cos of the angle between
        sum += arriving * phase_hg(dot(l, P) * inv_p);
    }
    return sum;
}

void main() {
    uvec3 g = uvec3(gl_GlobalInvocationID.xy, gl_WorkGroupID.z);
    if (g.x >= u_froxels.x || g.y >= u_froxels.y) return;
    uint id = froxel_id(g.x, g.y, g.z);
    uvec2 r = froxel_ranges[id].offset_count;
    uint h = 0u;
    for (uint e = 0u; e < r.y; ++e) h ^= froxel_mix(lights[froxel_entries[r.x + e]].id_type.x);
    froxel_stats[id] = uvec2(r.y, h);
    float u0 = edge_u(g.x), u1 = edge_u(g.x + 1u);
    float v0 = edge_v(g.y), v1 = edge_v(g.y + 1u);
    float z0 = edge_z(g.z), z1 = edge_z(g.z + 1u);
    vec3 sum = vec3(0.0);
    for (int s = 0; s < FROXEL_SAMPLES; ++s) {
        vec3 t = FROXEL_SAMPLES == 1 ? vec3(0.5)
                                     : vec3(0.25) + 0.5 * vec3(float(s & 1), float((s >> 1) & 1), float((s >> 2) & 1));
        float u = mix(u0, u1, t.x), v = mix(v0, v1, t.y), z = mix(z0, z1, t.z);
        sum += inscatter_at(vec3(u * u_tan.x * z, v * u_tan.y * z, -z), r.x, r.y);
    }
    froxel_light[id] = vec4(u_scattering * sum / float(FROXEL_SAMPLES), 0.0);
}
