// One scene light in view space as cpu_prep/lights.py computes it (the cull's and the pack's
// shared functions: _position, _direction, _sphere, _view_light), operation by operation in
// the types numba gives them: float64 where it does (`precise`: no fused multiply-add), and
// float32 where numba keeps float32 (e.g. a box's extent norm): each such operation done in
// float64 and rounded once, which gives the float32 operation's result bit for bit (a
// double's 53 bits are at least 2 x 24 + 2: +, -, x, / and sqrt round the same twice).
// Python's min and max are written out (the first argument kept unless the second is
// strictly less / greater), not GLSL's min / max, whose choice between -0 and +0 is open.
// Needs, declared before it: scene_words[] (the LIGHT_DTYPE records as uint words), the
// SL_* word offsets, u_view_x/y/z (rows of view_from_world), u_grow_scale, u_grow_eps,
// u_half_sqrt2.

uniform dvec4 u_view_x, u_view_y, u_view_z;  // rows of view_from_world
uniform double u_grow_scale, u_grow_eps;     // bounds.grow: 1 + RADIUS_REL_MARGIN, 4 float32 eps
uniform double u_half_sqrt2;                 // bounds.HALF_SQRT2

float word_f(uint i, uint w) { return uintBitsToFloat(scene_words[i * SL_WORDS + w]); }
vec3 word_v3(uint i, uint w) { return vec3(word_f(i, w), word_f(i, w + 1u), word_f(i, w + 2u)); }
dvec3 word_v(uint i, uint w) { return dvec3(word_v3(i, w)); }
uint light_type(uint i) { return scene_words[i * SL_WORDS + SL_TYPE] & 0xFFu; }   // uint8 first

double py_min(double a, double b) { return b < a ? b : a; }
double py_max(double a, double b) { return b > a ? b : a; }

// float32 arithmetic as numba's (see above)
float f32_mul(float a, float b) { precise double p = double(a) * double(b); return float(p); }
float f32_add(float a, float b) { precise double s = double(a) + double(b); return float(s); }
float f32_sub(float a, float b) { precise double s = double(a) - double(b); return float(s); }
float f32_sqrt(float a) { precise double s = sqrt(double(a)); return float(s); }

// lights._position_xyz: float64 transform, rounded to float32 once
vec3 view_position(dvec3 p) {
    precise double x = u_view_x.x * p.x + u_view_x.y * p.y + u_view_x.z * p.z + u_view_x.w;
    precise double y = u_view_y.x * p.x + u_view_y.y * p.y + u_view_y.z * p.z + u_view_y.w;
    precise double z = u_view_z.x * p.x + u_view_z.y * p.y + u_view_z.z * p.z + u_view_z.w;
    return vec3(float(x), float(y), float(z));
}

// lights._rotate: a world direction in view space, float64
dvec3 rotate(dvec3 v) {
    precise double x = u_view_x.x * v.x + u_view_x.y * v.y + u_view_x.z * v.z;
    precise double y = u_view_y.x * v.x + u_view_y.y * v.y + u_view_y.z * v.z;
    precise double z = u_view_z.x * v.x + u_view_z.y * v.y + u_view_z.z * v.z;
    return dvec3(x, y, z);
}

// lights._unit, float64
dvec3 unit(dvec3 v) {
    precise double len = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    precise double inv = 1.0lf / py_max(len, 1e-30lf);
    precise dvec3 u = dvec3(v.x * inv, v.y * inv, v.z * inv);
    return u;
}

// lights._direction_xyz: rotated, made unit length, rounded to float32
vec3 view_direction(dvec3 v) { return vec3(unit(rotate(v))); }

// the box's right axis (lights._view_light): normalize(cross(direction, rotated up))
vec3 box_right(vec3 d, dvec3 up) {
    dvec3 u = rotate(up);
    dvec3 f = dvec3(d);
    precise dvec3 c = dvec3(f.y * u.z - f.z * u.y, f.z * u.x - f.x * u.z, f.x * u.y - f.y * u.x);
    return vec3(unit(c));
}

// bounds.grow
double grow(double radius, dvec3 c) {
    precise double g = radius * u_grow_scale + u_grow_eps * sqrt(c.x * c.x + c.y * c.y + c.z * c.z);
    return g;
}

// bounds.spot_sphere (as _sphere calls it: float32 arguments, float64 from cos_a on)
dvec4 spot_sphere(dvec3 p, dvec3 d, double radius, double cos_outer) {
    precise double cos_a = py_min(py_max(cos_outer, 0.0lf), 1.0lf);
    precise double dist, rad;
    if (cos_a < u_half_sqrt2) {
        dist = cos_a * radius;
        rad = sqrt(1.0lf - cos_a * cos_a) * radius;
    } else {
        dist = radius / (2.0lf * cos_a);
        rad = dist;
    }
    if (rad >= radius) return dvec4(p, radius);
    precise dvec3 c = dvec3(p.x + d.x * dist, p.y + d.y * dist, p.z + d.z * dist);
    return dvec4(c, rad);
}

// lights._sphere: the float64 culling sphere from the stored position and (spots) direction,
// margins of grow() included; a box's extent norm is float32 arithmetic in numba
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
        vec3 e = word_v3(i, SL_EXTENT);
        r = double(f32_sqrt(f32_add(f32_add(f32_mul(e.x, e.x), f32_mul(e.y, e.y)), f32_mul(e.z, e.z))));
    }
    return dvec4(c, grow(r, c));
}
