#version 430
// The pack on the GPU, cpu_prep/lights.py's pack bit for bit: each visible light, in the
// depth order of the sort, from its scene record (build_light.glsl's view-space values and
// culling sphere, build_bounds.glsl's screen rectangle and depth range):
//   lights[j]   GPU_LIGHT: position and radius, colour x intensity and cos inner, direction
//               and cos outer, scene id and type, extents and length, a box's right axis
//   bounds[j]   GPU_BOUND: the sphere as float32, its radius rounded up
//   spheres[j]  the float64 sphere;  rects[j]  the float64 pixel rectangle (x0, x1, y0, y1)
//   depths[j]   the float32 depth range, rounded outwards (next_down / next_up)
// The pack's SIMD loops and its scalar fix-ups compute the same values for every light
// (lights.py _pack_block): one path here, bounds.shape_bounds for every shape.
// define: SL_WORDS SL_TYPE SL_POSITION SL_RADIUS SL_COLOR SL_INTENSITY SL_DIRECTION SL_COS_INNER SL_COS_OUTER SL_LENGTH SL_UP SL_EXTENT LW_POS LW_COLOR LW_DIR LW_ID LW_EXT LW_RIGHT LW_WORDS
#include "generated.glsl"
#include "build_common.glsl"
#include "build_counters.glsl"

layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
layout(std430, binding = B_SCENE_LIGHTS) readonly buffer SceneLights { uint scene_words[]; };
layout(std430, binding = B_SORTED_IDS) readonly buffer SortedIds { uint sorted_ids[]; };
layout(std430, binding = B_LIGHTS) buffer Lights { uint light_words[]; };
layout(std430, binding = B_BOUNDS) buffer Bounds_ { vec4 bounds[]; };
layout(std430, binding = B_SPHERES) buffer Spheres { dvec4 spheres[]; };
layout(std430, binding = B_RECTS) buffer Rects { dvec4 rects[]; };
layout(std430, binding = B_DEPTHS) buffer Depths { uint depth_words[]; };

#include "build_light.glsl"
#include "build_bounds.glsl"

// intrinsics.next_up_f32 / next_down_f32 on the bits (no float operation: a denormal stays)
uint next_up_bits(uint u) {
    uint mag = u & 0x7FFFFFFFu;
    if (mag > 0x7F800000u || u == 0x7F800000u) return u;          // NaN, +inf
    if (mag == 0u) return 1u;                                      // +-0: the least subnormal
    return (u >> 31) == 0u ? u + 1u : u - 1u;
}
uint next_down_bits(uint u) {
    uint mag = u & 0x7FFFFFFFu;
    if (mag > 0x7F800000u || u == 0xFF800000u) return u;          // NaN, -inf
    if (mag == 0u) return 0x80000001u;
    return (u >> 31) == 0u ? u - 1u : u + 1u;
}

void put4(uint j, uint field, vec4 v) {
    uint w = j * LW_WORDS + field;
    light_words[w] = floatBitsToUint(v.x);
    light_words[w + 1u] = floatBitsToUint(v.y);
    light_words[w + 2u] = floatBitsToUint(v.z);
    light_words[w + 3u] = floatBitsToUint(v.w);
}

// a float32 field of the scene record copied as its bits
void copy_word(uint j, uint field, uint i, uint w) { light_words[j * LW_WORDS + field] = scene_words[i * SL_WORDS + w]; }

void main() {
    uint j = element_index();
    if (j >= counters[COUNTER_VISIBLE]) return;
    uint i = sorted_ids[j];
    uint t = light_type(i);
    vec3 p = view_position(word_v(i, SL_POSITION));
    vec3 d = view_direction(word_v(i, SL_DIRECTION));
    vec3 right = t == LIGHT_BOX ? box_right(d, word_v(i, SL_UP)) : vec3(0.0);
    dvec4 s = culling_sphere(i, t, p, d);
    float radius = word_f(i, SL_RADIUS), cos_outer = word_f(i, SL_COS_OUTER), len = word_f(i, SL_LENGTH);
    float intensity = word_f(i, SL_INTENSITY);
    vec3 c = word_v3(i, SL_COLOR);
    put4(j, LW_POS, vec4(p, 0.0));
    copy_word(j, LW_POS + 3u, i, SL_RADIUS);
    put4(j, LW_COLOR, vec4(f32_mul(c.x, intensity), f32_mul(c.y, intensity), f32_mul(c.z, intensity), 0.0));
    copy_word(j, LW_COLOR + 3u, i, SL_COS_INNER);
    put4(j, LW_DIR, vec4(d, 0.0));
    copy_word(j, LW_DIR + 3u, i, SL_COS_OUTER);
    uint w = j * LW_WORDS + LW_ID;
    light_words[w] = i;
    light_words[w + 1u] = t;
    light_words[w + 2u] = 0u;
    light_words[w + 3u] = 0u;
    for (uint k = 0u; k < 3u; ++k) copy_word(j, LW_EXT + k, i, SL_EXTENT + k);
    copy_word(j, LW_EXT + 3u, i, SL_LENGTH);
    put4(j, LW_RIGHT, vec4(right, 0.0));
    spheres[j] = s;
    bounds[j] = vec4(vec3(s.xyz), uintBitsToFloat(next_up_bits(floatBitsToUint(float(s.w)))));
    Bounds b = shape_bounds(t, p, d, right, radius, cos_outer, len, word_v3(i, SL_EXTENT), s);
    rects[j] = b.rect;
    depth_words[2u * j] = next_down_bits(floatBitsToUint(float(b.depth.x)));
    depth_words[2u * j + 1u] = next_up_bits(floatBitsToUint(float(b.depth.y)));
}
