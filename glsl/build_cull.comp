#version 430
// The frame's cull on the GPU, cpu_prep/lights.py's _cull in the same float64 operations in
// the same order (`precise`: no fused multiply-add, so every value is numba's, bit for bit):
//   CULL_STEP 0  per scene light: visible or not (flags[], scanned next by build_scan.comp)
//                and its sort key, the float32 bits of its sphere-centre depth made to order
//                like the values
//   CULL_STEP 1  the visible ones in scene order: keys[place], values[place] = scene id
//                (the depth sort is stable, so ties keep scene order, as the CPU's)
// define: CULL_STEP SL_WORDS SL_TYPE SL_POSITION SL_RADIUS SL_DIRECTION SL_COS_OUTER SL_LENGTH SL_EXTENT
#include "generated.glsl"
#include "build_common.glsl"

uniform uint u_n;                 // scene lights

layout(std430, binding = B_FLAGS) buffer Flags { uint flags[]; };
layout(std430, binding = B_CULL_KEYS) buffer CullKeys { uint cull_keys[]; };
#if CULL_STEP == 0
layout(std430, binding = B_SCENE_LIGHTS) readonly buffer SceneLights { uint scene_words[]; };

uniform dvec4 u_view_x, u_view_y, u_view_z;  // rows of view_from_world
uniform double u_near_lo, u_far_hi;          // near * (1 - RADIUS_REL_MARGIN), far * (1 + ..)
uniform double u_tan_x, u_tan_y;             // the side planes, widened by PIXEL_MARGIN
uniform double u_norm_x, u_norm_y;           // sqrt(1 + tan^2)
uniform double u_grow_scale, u_grow_eps;     // bounds.grow: 1 + RADIUS_REL_MARGIN, 4 float32 eps
uniform double u_half_sqrt2;                 // bounds.HALF_SQRT2

float word_f(uint i, uint w) { return uintBitsToFloat(scene_words[i * SL_WORDS + w]); }
dvec3 word_v(uint i, uint w) { return dvec3(word_f(i, w), word_f(i, w + 1u), word_f(i, w + 2u)); }

// lights._position_xyz: float64 transform, rounded to float32 once
vec3 view_position(dvec3 p) {
    precise double x = u_view_x.x * p.x + u_view_x.y * p.y + u_view_x.z * p.z + u_view_x.w;
    precise double y = u_view_y.x * p.x + u_view_y.y * p.y + u_view_y.z * p.z + u_view_y.w;
    precise double z = u_view_z.x * p.x + u_view_z.y * p.y + u_view_z.z * p.z + u_view_z.w;
    return vec3(float(x), float(y), float(z));
}

// lights._direction_xyz: rotated, made unit length (lights._unit), rounded to float32
vec3 view_direction(dvec3 v) {
    precise double x = u_view_x.x * v.x + u_view_x.y * v.y + u_view_x.z * v.z;
    precise double y = u_view_y.x * v.x + u_view_y.y * v.y + u_view_y.z * v.z;
    precise double z = u_view_z.x * v.x + u_view_z.y * v.y + u_view_z.z * v.z;
    precise double len = sqrt(x * x + y * y + z * z);
    precise double inv = 1.0lf / max(len, 1e-30lf);
    precise double ux = x * inv, uy = y * inv, uz = z * inv;
    return vec3(float(ux), float(uy), float(uz));
}

// bounds.grow
double grow(double radius, dvec3 c) {
    precise double g = radius * u_grow_scale + u_grow_eps * sqrt(c.x * c.x + c.y * c.y + c.z * c.z);
    return g;
}

// bounds.spot_sphere
dvec4 spot_sphere(dvec3 p, dvec3 d, double radius, double cos_outer) {
    precise double cos_a = min(max(cos_outer, 0.0lf), 1.0lf);
    precise double dist, rad;
    if (cos_a < u_half_sqrt2) {
        dist = cos_a * radius;
        rad = sqrt(1.0lf - cos_a * cos_a) * radius;
    } else {
        dist = radius / (2.0lf * cos_a);
        rad = dist;
    }
    if (rad >= radius) return dvec4(p, radius);
    precise dvec3 c = p + d * dist;
    return dvec4(c, rad);
}

// lights._sphere: the float64 culling sphere, margins of grow() included
dvec4 culling_sphere(uint i, uint t, vec3 p, vec3 d) {
    precise dvec3 c = dvec3(p);
    precise double r = double(word_f(i, SL_RADIUS));
    if (t == LIGHT_SPOT) {
        dvec4 s = spot_sphere(c, dvec3(d), r, double(word_f(i, SL_COS_OUTER)));
        c = s.xyz;
        r = s.w;
    } else if (t == LIGHT_CAPSULE) {
        r += 0.5lf * double(word_f(i, SL_LENGTH));
    } else if (t == LIGHT_BOX) {
        dvec3 e = word_v(i, SL_EXTENT);
        r = sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
    }
    return dvec4(c, grow(r, c));
}

// lights._float_key
uint float_key(uint bits) { return (bits >> 31) != 0u ? ~bits : bits | 0x80000000u; }

void main() {
    uint i = element_index();
    if (i >= u_n) return;
    uint t = scene_words[i * SL_WORDS + SL_TYPE] & 0xFFu;     // uint8 at the record's start
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
