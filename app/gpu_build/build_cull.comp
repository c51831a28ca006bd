#version 430
// The frame's cull on the GPU, cpu_prep/lights.py's _cull in the same operations in the same
// order and types (build_light.glsl: every value is numba's, bit for bit):
//   CULL_STEP 0  per scene light: visible or not (flags[], scanned next by build_scan.comp)
//                and its sort key, the float32 bits of its sphere-centre depth made to order
//                like the values; a visible light's type bit into counters[COUNTER_TYPES]
//   CULL_STEP 1  the visible ones in scene order: keys[place], values[place] = scene id
//                (the depth sort is stable, so ties keep scene order, as the CPU's)
// define: CULL_STEP SL_WORDS SL_TYPE SL_POSITION SL_RADIUS SL_COLOR SL_INTENSITY SL_DIRECTION SL_COS_INNER SL_COS_OUTER SL_LENGTH SL_UP SL_EXTENT
#include "generated.glsl"
#include "build_common.glsl"
#include "build_counters.glsl"

uniform uint u_n;                 // scene lights

layout(std430, binding = B_FLAGS) buffer Flags { uint flags[]; };
layout(std430, binding = B_CULL_KEYS) buffer CullKeys { uint cull_keys[]; };
#if CULL_STEP == 0
layout(std430, binding = B_SCENE_LIGHTS) readonly buffer SceneLights { uint scene_words[]; };
layout(std430, binding = B_COUNTERS) buffer Counters { uint counters[]; };

uniform double u_near_lo, u_far_hi;          // near * (1 - RADIUS_REL_MARGIN), far * (1 + ..)
uniform double u_tan_x, u_tan_y;             // the side planes, widened by PIXEL_MARGIN
uniform double u_norm_x, u_norm_y;           // sqrt(1 + tan^2)
#include "build_light.glsl"

// lights._float_key
uint float_key(uint bits) { return (bits >> 31) != 0u ? ~bits : bits | 0x80000000u; }

void main() {
    uint i = element_index();
    if (i >= u_n) return;
    uint t = light_type(i);
    vec3 p = view_position(word_v(i, SL_POSITION));
    vec3 d = t == LIGHT_SPOT ? view_direction(word_v(i, SL_DIRECTION)) : vec3(0.0);
    dvec4 s = culling_sphere(i, t, p, d);
    precise double depth = -s.z;
    precise double rx = s.w * u_norm_x, ry = s.w * u_norm_y;
    precise double dr_lo = depth + s.w, dr_hi = depth - s.w;
    precise double sx = u_tan_x * depth, sy = u_tan_y * depth;
    precise double l = s.x + sx, r = -s.x + sx, b = s.y + sy, top = -s.y + sy;
    // the tests as the rejections they are: a NaN sphere is kept, as the CPU keeps it
    bool culled = dr_lo < u_near_lo || dr_hi > u_far_hi || l < -rx || r < -rx || b < -ry || top < -ry;
    flags[i] = culled ? 0u : 1u;
    if (!culled) atomicOr(counters[COUNTER_TYPES], 1u << t);     // the shapes the frame compiles
    cull_keys[i] = float_key(floatBitsToUint(float(depth)));
}
#else
layout(std430, binding = B_PLACES) readonly buffer Places { uint places[]; };
layout(std430, binding = B_KEYS) buffer Keys { uint keys[]; };
layout(std430, binding = B_VALUES) buffer Values { uint values[]; };

void main() {
    uint i = element_index();
    if (i >= u_n || flags[i] == 0u) return;
    keys[places[i]] = cull_keys[i];
    values[places[i]] = i;
}
#endif
