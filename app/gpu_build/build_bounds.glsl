// Each light shape's screen rectangle and depth range, cpu_prep/bounds.py's shape_bounds bit
// for bit (build_pack.comp): the same operations in the same order and in the types numba
// gives them for the pack's arguments (stored values float32, the sphere float64): float64
// but where the listed float32 operations are (a box's up axis and centre norm, a spot
// pyramid's third axis component), each done as build_light.glsl's f32_* do them.
// Needs build_light.glsl before it, and u_near, u_tan (the half-angle tangents, x and y),
// u_size (the screen in pixels), u_pixel_margin, u_pad_scale, u_wide_cone_cos.

uniform double u_near;
uniform dvec2 u_tan;                 // tan_half_x, tan_half_y
uniform dvec2 u_size;                // width, height in pixels
uniform double u_pixel_margin;       // limits.PIXEL_MARGIN
uniform double u_pad_scale;          // box_bounds: RADIUS_REL_MARGIN + 8 float32 eps
uniform double u_wide_cone_cos;      // bounds.WIDE_CONE_COS

const uint SHAPE_PIECES = 4u;        // bounds.SHAPE_PIECES

double d_inf() { return packDouble2x32(uvec2(0u, 0x7FF00000u)); }

// (x0, x1, y0, y1) and (d0, d1) of a light's bounds, as the tuples bounds.py passes on
struct Bounds { dvec4 rect; dvec2 depth; };

Bounds empty_bounds() { double inf = d_inf(); return Bounds(dvec4(inf, -inf, inf, -inf), dvec2(inf, -inf)); }

// bounds.project_axis_ahead: a sphere wholly in front of the near plane (one axis, NDC)
dvec2 project_axis_ahead(double ca, double cz, double r, double tan_half) {
    precise double t = sqrt(ca * ca + cz * cz - r * r);
    precise double tca = t * ca, tcz = t * cz, rca = r * ca, rcz = r * cz;
    precise double n0 = (tca + rcz) / ((rca - tcz) * tan_half);
    precise double n1 = (tca - rcz) / ((-rca - tcz) * tan_half);
    return dvec2(py_min(n0, n1), py_max(n0, n1));
}

// bounds.project_axis_general: Mara & McGuire's listing 1, every case
dvec2 project_axis_general(double ca, double cz, double r, double near_z, double tan_half) {
    precise double length2 = ca * ca + cz * cz;
    precise double t2 = length2 - r * r;
    bool inside = t2 <= 0.0lf;
    precise double vx = 0.0lf, vy = 0.0lf;
    if (!inside) {
        precise double len = sqrt(length2);
        vx = sqrt(t2) / len;
        vy = r / len;
    }
    bool clip_sphere = cz + r >= near_z;
    precise double k = sqrt(py_max(r * r - (near_z - cz) * (near_z - cz), 0.0lf));
    double lo = d_inf(), hi = -d_inf();
    for (int s = 0; s < 2; ++s) {
        double sign = s == 0 ? 1.0lf : -1.0lf;
        precise double sy = sign * vy;
        precise double ba = (vx * ca + sy * cz) * vx;
        precise double bz = (-sy * ca + vx * cz) * vx;
        if (clip_sphere && (inside || bz > near_z)) {
            ba = ca - sign * k;
            bz = near_z;
        }
        precise double n = ba / (-bz * tan_half);
        lo = py_min(lo, n);
        hi = py_max(hi, n);
    }
    return dvec2(lo, hi);
}

// bounds.project_axis
dvec2 project_axis(double ca, double cz, double r, double near_z, double tan_half) {
    return cz + r < near_z ? project_axis_ahead(ca, cz, r, tan_half)
                           : project_axis_general(ca, cz, r, near_z, tan_half);
}

// bounds.ndc_rect: pixels, PIXEL_MARGIN added
dvec4 ndc_rect(dvec2 x, dvec2 y) {
    precise dvec4 r = dvec4((x.x * 0.5lf + 0.5lf) * u_size.x - u_pixel_margin,
                            (x.y * 0.5lf + 0.5lf) * u_size.x + u_pixel_margin,
                            (y.x * 0.5lf + 0.5lf) * u_size.y - u_pixel_margin,
                            (y.y * 0.5lf + 0.5lf) * u_size.y + u_pixel_margin);
    return r;
}

// bounds.pixel_rect
dvec4 pixel_rect(dvec4 s) {
    return ndc_rect(project_axis(s.x, s.z, s.w, -u_near, u_tan.x), project_axis(s.y, s.z, s.w, -u_near, u_tan.y));
}

// bounds._cover: the union with a sphere's bounds
Bounds cover(Bounds b, dvec4 s) {
    dvec4 a = pixel_rect(s);
    precise double d0 = -s.z - s.w, d1 = -s.z + s.w;
    return Bounds(dvec4(py_min(b.rect.x, a.x), py_max(b.rect.y, a.y), py_min(b.rect.z, a.z), py_max(b.rect.w, a.w)),
                  dvec2(py_min(b.depth.x, d0), py_max(b.depth.y, d1)));
}

// bounds._box_point: a point in front of the eye added to the bounds
Bounds box_point(Bounds b, dvec3 q) {
    precise double sx = (q.x / (-q.z * u_tan.x) * 0.5lf + 0.5lf) * u_size.x;
    precise double sy = (q.y / (-q.z * u_tan.y) * 0.5lf + 0.5lf) * u_size.y;
    return Bounds(dvec4(py_min(b.rect.x, sx), py_max(b.rect.y, sx), py_min(b.rect.z, sy), py_max(b.rect.w, sy)),
                  dvec2(py_min(b.depth.x, -q.z), py_max(b.depth.y, -q.z)));
}

// bounds._corner k (bits: +right, +up', +direction); `back` scales the -direction face
dvec3 corner(uint k, dvec3 p, dvec3 r, dvec3 u, dvec3 d, dvec3 e, double back) {
    double f = (k & 4u) != 0u ? 1.0lf : back;
    precise double sx = (k & 1u) != 0u ? e.x * f : -e.x * f;
    precise double sy = (k & 2u) != 0u ? e.y * f : -e.y * f;
    double sz = (k & 4u) != 0u ? e.z : -e.z;
    precise dvec3 c = dvec3(p.x + r.x * sx + u.x * sy + d.x * sz, p.y + r.y * sx + u.y * sy + d.y * sz,
                            p.z + r.z * sx + u.z * sy + d.z * sz);
    return c;
}

// bounds.box_bounds from its up axis and padded half extents (their types are the caller's:
// box_bounds_f32 / spot_pyramid): corners in front of the near plane and the edges' crossings
Bounds box_bounds(dvec3 p, dvec3 d, dvec3 r, dvec3 u, dvec3 e, double back) {
    Bounds b = empty_bounds();
    double zn = -u_near;
    for (uint k = 0u; k < 8u; ++k) {
        dvec3 a = corner(k, p, r, u, d, e, back);
        if (a.z <= zn) b = box_point(b, a);
        for (uint bit = 1u; bit <= 4u; bit <<= 1) {
            uint j = k | bit;
            if (j == k) continue;
            dvec3 c = corner(j, p, r, u, d, e, back);
            precise double side = (a.z - zn) * (c.z - zn);
            if (side < 0.0lf) {
                precise double t = (zn - a.z) / (c.z - a.z);
                precise double qx = a.x + (c.x - a.x) * t, qy = a.y + (c.y - a.y) * t;
                b = box_point(b, dvec3(qx, qy, zn));
            }
        }
    }
    b.rect = dvec4(b.rect.x - u_pixel_margin, b.rect.y + u_pixel_margin,
                   b.rect.z - u_pixel_margin, b.rect.w + u_pixel_margin);
    return b;
}

// box_bounds as shape_bounds calls it for a box: every argument float32, so numba computes
// up' = right x dir and the centre's norm in float32
Bounds box_bounds_f32(vec3 p, vec3 d, vec3 r, vec3 e) {
    vec3 u = vec3(f32_sub(f32_mul(r.y, d.z), f32_mul(r.z, d.y)), f32_sub(f32_mul(r.z, d.x), f32_mul(r.x, d.z)),
                  f32_sub(f32_mul(r.x, d.y), f32_mul(r.y, d.x)));
    float biggest = e.y > e.x ? e.y : e.x;
    biggest = e.z > biggest ? e.z : biggest;
    float norm = f32_sqrt(f32_add(f32_add(f32_mul(p.x, p.x), f32_mul(p.y, p.y)), f32_mul(p.z, p.z)));
    precise double pad = u_pad_scale * double(biggest) + u_grow_eps * double(norm);
    precise dvec3 ep = dvec3(double(e.x) + pad, double(e.y) + pad, double(e.z) + pad);
    return box_bounds(dvec3(p), dvec3(d), dvec3(r), dvec3(u), ep, 1.0lf);
}

// bounds.spot_pyramid (float32 arguments): its right axis' third component stays float32 in
// numba (both branches give it a float32), the other two float64
Bounds spot_pyramid(vec3 p, vec3 d, float radius, float cos_outer) {
    precise double cos_a = py_min(py_max(double(cos_outer), u_wide_cone_cos), 1.0lf);
    precise double w = double(radius) * sqrt(1.0lf - cos_a * cos_a) / cos_a;
    double rx, ry;
    float rz;
    if (abs(double(d.x)) < 0.6lf) {
        rx = 0.0lf; ry = double(-d.z); rz = d.y;
    } else {
        rx = double(d.z); ry = 0.0lf; rz = -d.x;
    }
    precise double n = sqrt(rx * rx + ry * ry + double(f32_mul(rz, rz)));
    precise dvec3 r = dvec3(rx / n, ry / n, double(rz) / n);
    precise double h = 0.5lf * double(radius);
    dvec3 dd = dvec3(d);
    precise dvec3 c = dvec3(double(p.x) + dd.x * h, double(p.y) + dd.y * h, double(p.z) + dd.z * h);
    precise dvec3 u = dvec3(r.y * dd.z - r.z * dd.y, r.z * dd.x - r.x * dd.z, r.x * dd.y - r.y * dd.x);
    precise double biggest = py_max(py_max(w, w), h);
    precise double pad = u_pad_scale * biggest + u_grow_eps * sqrt(c.x * c.x + c.y * c.y + c.z * c.z);
    return box_bounds(c, dd, r, u, dvec3(w + pad, w + pad, h + pad), 0.0lf);
}

// bounds.capsule_pieces (float32 arguments, float64 from the piece on)
Bounds capsule_pieces(vec3 p, vec3 d, float radius, float len) {
    Bounds b = empty_bounds();
    precise double piece = double(len) / double(SHAPE_PIECES);
    for (uint k = 0u; k < SHAPE_PIECES; ++k) {
        precise double t = -0.5lf * double(len) + piece * (double(k) + 0.5lf);
        precise dvec3 c = dvec3(double(p.x) + double(d.x) * t, double(p.y) + double(d.y) * t,
                                double(p.z) + double(d.z) * t);
        precise double r0 = double(radius) + 0.5lf * piece;
        b = cover(b, dvec4(c, grow(r0, c)));
    }
    return b;
}

// bounds.sphere_only
bool sphere_only(uint t, float cos_outer, float len) {
    return !((t == LIGHT_SPOT && double(cos_outer) >= u_wide_cone_cos) ||
             (t == LIGHT_CAPSULE && len > 0.0) || t == LIGHT_BOX);
}

// bounds.shape_bounds: the culling sphere's bounds, tightened by the shape's own cover
Bounds shape_bounds(uint t, vec3 p, vec3 d, vec3 r, float radius, float cos_outer, float len,
                    vec3 e, dvec4 s) {
    precise double d0 = -s.z - s.w, d1 = -s.z + s.w;
    Bounds b = Bounds(pixel_rect(s), dvec2(d0, d1));
    if (sphere_only(t, cos_outer, len)) return b;
    Bounds a = t == LIGHT_SPOT ? spot_pyramid(p, d, radius, cos_outer)
             : t == LIGHT_CAPSULE ? capsule_pieces(p, d, radius, len) : box_bounds_f32(p, d, r, e);
    return Bounds(dvec4(py_max(b.rect.x, a.rect.x), py_min(b.rect.y, a.rect.y),
                        py_max(b.rect.z, a.rect.z), py_min(b.rect.w, a.rect.w)),
                  dvec2(py_max(b.depth.x, a.depth.x), py_min(b.depth.y, a.depth.y)));
}
