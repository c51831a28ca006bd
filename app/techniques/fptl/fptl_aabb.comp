#version 430
// fptl, step 1(c) of the chapter: per visible light, in class order, the tight screen-space
// AABB and depth range of the part of its volume inside the view frustum:
//   * the light's convex bound: an OBB whose face on the -axis side may be scaled (the
//     chapter's OBB with a scaled top face): a spot's pyramid (apex at the light, base at
//     the radius; past 45 degrees the half box), a capsule's box, a box light's own box, a
//     point light's cube;
//   * each of its six faces clipped against the frustum (Sutherland-Hodgman), and the
//     frustum's eight corners that lie inside the bound: together the vertices of
//     bound ∩ frustum, whose projection's AABB is the rectangle;
//   * intersected with the AABB of the light's bounding sphere (Mara & McGuire 2013, as
//     cpu_prep.bounds.project_axis; the sphere of the frame's bounds[], margins included).
// Conservative with respect to the float32 test of evaluate_light: double precision here,
// the bound grown by the float32 test's own error (FPTL_REL_MARGIN = limits.RADIUS_REL_MARGIN
// relative, a few float32 ulp of the position and the extents; a spot's cosine lowered by 32
// ulp), the frustum widened by two pixels and its near plane pulled in, and the rectangle
// grown by FPTL_PIXEL_MARGIN (limits.PIXEL_MARGIN: where a pixel's position projects).
// An empty intersection gives an empty AABB (x0 > x1): the light meets no tile.
// define: FPTL_REL_MARGIN FPTL_PIXEL_MARGIN
#include "generated.glsl"
#include "fptl_structs.glsl"
layout(local_size_x = 64) in;

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = B_BOUNDS) readonly buffer Bounds { GpuBound bounds[]; };
layout(std430, binding = B_FPTL_ORDER) readonly buffer Order { uint fptl_order[]; };
layout(std430, binding = B_FPTL_AABBS) writeonly buffer Aabbs { FptlAabb fptl_aabbs[]; };

uniform uint u_light_count;
uniform ivec2 u_size;
uniform vec2 u_tan_half;       // the camera's tan of the half field of view, x and y
uniform vec2 u_near_far;

const double EPS32 = 1.1920928955078125e-7lf;   // float32 epsilon
const double REL = double(FPTL_REL_MARGIN);
const double HALF_SQRT2 = 0.70710678118654752lf;

// The convex bound: centre, axes, half length along axis 2, half extents (axes 0 and 1) of
// its face at -ez (e0) and at +ez (e1).
dvec3 b_c, b_a0, b_a1, b_a2;
double b_ez;
dvec2 b_e0, b_e1;

// The frustum the bound is clipped to (widened): tan x, tan y, near, far.
dvec2 f_tan;
double f_near, f_far;

// The accumulated AABB: pixels (GL) and view depth.
dvec2 g_lo, g_hi;
double g_dlo, g_dhi;
bool g_full;                   // a clip ran out of room: take the whole screen

void add_point(dvec3 p) {
    double depth = -p.z;       // >= near after the near clip
    dvec2 px = (p.xy / (depth * dvec2(u_tan_half)) * 0.5lf + 0.5lf) * dvec2(u_size);
    g_lo = min(g_lo, px);
    g_hi = max(g_hi, px);
    g_dlo = min(g_dlo, depth);
    g_dhi = max(g_dhi, depth);
}

dvec3 corner(int k) {
    dvec2 e = (k & 4) != 0 ? b_e1 : b_e0;
    return b_c + b_a0 * ((k & 1) != 0 ? e.x : -e.x) + b_a1 * ((k & 2) != 0 ? e.y : -e.y)
               + b_a2 * ((k & 4) != 0 ? b_ez : -b_ez);
}

// Frustum plane k, inside where dot(n, p) + w <= 0.
dvec4 plane(int k) {
    if (k == 0) return dvec4(1.0lf, 0.0lf, f_tan.x, 0.0lf);      // x <= tan_x * depth
    if (k == 1) return dvec4(-1.0lf, 0.0lf, f_tan.x, 0.0lf);
    if (k == 2) return dvec4(0.0lf, 1.0lf, f_tan.y, 0.0lf);
    if (k == 3) return dvec4(0.0lf, -1.0lf, f_tan.y, 0.0lf);
    if (k == 4) return dvec4(0.0lf, 0.0lf, 1.0lf, f_near);       // depth >= near
    return dvec4(0.0lf, 0.0lf, -1.0lf, -f_far);                  // depth <= far
}

#define MAX_POLY 16
// Face f of the bound (corner bits: 1 axis 0, 2 axis 1, 4 axis 2), in cyclic order.
const int FACES[24] = int[24](0, 2, 6, 4,  1, 3, 7, 5,  0, 1, 5, 4,  2, 3, 7, 6,  0, 1, 3, 2,  4, 5, 7, 6);

void clip_face(int f) {
    dvec3 poly[MAX_POLY], next[MAX_POLY];
    int n = 4;
    for (int i = 0; i < 4; ++i) poly[i] = corner(FACES[f * 4 + i]);
    for (int k = 0; k < 6 && n > 0; ++k) {
        dvec4 pl = plane(k);
        int m = 0;
        for (int i = 0; i < n; ++i) {
            dvec3 a = poly[i], b = poly[(i + 1) % n];
            double da = dot(pl.xyz, a) + pl.w, db = dot(pl.xyz, b) + pl.w;
            if (m + 2 > MAX_POLY) { g_full = true; return; }
            if (da <= 0.0lf) next[m++] = a;
            if ((da < 0.0lf && db > 0.0lf) || (da > 0.0lf && db < 0.0lf))
                next[m++] = a + (b - a) * (da / (da - db));
        }
        for (int i = 0; i < m; ++i) poly[i] = next[i];
        n = m;
    }
    for (int i = 0; i < n; ++i) add_point(poly[i]);
}

// A frustum corner inside the bound (with a tolerance: taking one too many only grows it).
bool inside_bound(dvec3 p) {
    dvec3 l = p - b_c;
    double tol = 1e-6lf * (b_ez + max(max(b_e0.x, b_e0.y), max(b_e1.x, b_e1.y))) + 1e-9lf;
    double z = dot(l, b_a2);
    if (abs(z) > b_ez + tol) return false;
    double t = b_ez > 0.0lf ? clamp((z + b_ez) / (2.0lf * b_ez), 0.0lf, 1.0lf) : 1.0lf;
    dvec2 e = mix(b_e0, b_e1, t);
    return abs(dot(l, b_a0)) <= e.x + tol && abs(dot(l, b_a1)) <= e.y + tol;
}

// Two unit vectors across a unit axis (from the view axis least aligned with it).
void across(dvec3 d, out dvec3 a0, out dvec3 a1) {
    a0 = normalize(abs(d.x) < 0.6lf ? cross(dvec3(1.0lf, 0.0lf, 0.0lf), d)
                                    : cross(dvec3(0.0lf, 1.0lf, 0.0lf), d));
    a1 = cross(d, a0);
}

// The light's convex bound, grown by the float32 test's error (module comment).
void make_bound(GpuLight L) {
    dvec3 p = dvec3(L.pos_radius.xyz);
    double r = double(L.pos_radius.w);
    double at = length(p);
    uint type = L.id_type.y;
    b_a0 = dvec3(1.0lf, 0.0lf, 0.0lf); b_a1 = dvec3(0.0lf, 1.0lf, 0.0lf); b_a2 = dvec3(0.0lf, 0.0lf, 1.0lf);
    if (type == LIGHT_BOX) {
        dvec3 e = dvec3(L.extent_length.xyz);
        double em = max(max(e.x, e.y), e.z);
        double pad = (REL + 16.0lf * EPS32) * em + 8.0lf * EPS32 * at + 1e-30lf;
        b_c = p;
        b_a0 = dvec3(L.right.xyz);
        b_a2 = dvec3(L.dir_cos_outer.xyz);
        b_a1 = cross(b_a0, b_a2);               // up' = cross(right, direction), as box_local
        b_ez = e.z + pad;
        b_e0 = b_e1 = e.xy + pad;
        return;
    }
    dvec3 d = normalize(dvec3(L.dir_cos_outer.xyz));
    if (type == LIGHT_CAPSULE) {
        double len = double(L.extent_length.w);
        double slack = 16.0lf * EPS32 * (at + len + r);
        double re = r * (1.0lf + REL) + slack;
        b_c = p;
        b_a2 = d;
        across(d, b_a0, b_a1);
        b_ez = 0.5lf * len * (1.0lf + REL) + slack + re;
        b_e0 = b_e1 = dvec2(re);
        return;
    }
    double re = r * (1.0lf + REL) + 8.0lf * EPS32 * (at + r);
    if (type == LIGHT_SPOT) {
        // points of the volume: axial t in (0, r], lateral <= t tan(outer); the float32 cone
        // test errs by ~10 ulp of the cosine: lower it by 32 ulp
        double pad = 8.0lf * EPS32 * (at + r) + REL * r;
        double c = double(L.dir_cos_outer.w) - 32.0lf * EPS32;
        b_a2 = d;
        across(d, b_a0, b_a1);
        b_c = p + d * (0.5lf * (re - pad));     // axial range [-pad, re]
        b_ez = 0.5lf * (re + pad);
        if (c <= HALF_SQRT2) {                  // past 45 degrees: lateral <= r, the half box
            b_e0 = b_e1 = dvec2(re);
        } else {
            double t = sqrt((1.0lf - c) * (1.0lf + c)) / c;
            b_e0 = dvec2(pad);                  // the scaled (apex) face
            b_e1 = dvec2(re * t * (1.0lf + REL) + pad);
        }
        return;
    }
    b_c = p;                                    // point (and a fallback): the cube
    b_ez = re;
    b_e0 = b_e1 = dvec2(re);
}

// Mara & McGuire 2013, listing 1, one axis, double precision (cpu_prep.bounds.project_axis,
// with its -z-forward pairing of the tangent and the near-plane chord end): NDC range.
dvec2 sphere_axis(double ca, double cz, double r, double near_z, double tan_half) {
    double length2 = ca * ca + cz * cz;
    double t2 = length2 - r * r;
    bool inside = t2 <= 0.0lf;
    double vx = 0.0lf, vy = 0.0lf;
    if (!inside) {
        double len = sqrt(length2);
        vx = sqrt(t2) / len;
        vy = r / len;
    }
    bool clip_sphere = cz + r >= near_z;
    double k = sqrt(max(r * r - (near_z - cz) * (near_z - cz), 0.0lf));
    double lo = 1e300lf, hi = -1e300lf;
    for (int s = 0; s < 2; ++s) {
        double sign = s == 0 ? 1.0lf : -1.0lf;
        double sy = sign * vy;
        double ba = (vx * ca + sy * cz) * vx;
        double bz = (-sy * ca + vx * cz) * vx;
        if (clip_sphere && (inside || bz > near_z)) {
            ba = ca - sign * k;
            bz = near_z;
        }
        double n = ba / (-bz * tan_half);
        lo = min(lo, n);
        hi = max(hi, n);
    }
    return dvec2(lo, hi);
}

// priced: aabb
void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= u_light_count) return;
    uint li = fptl_order[k];
    GpuLight L = lights[li];
    // the frustum, two pixels wider on each side, the near plane pulled in, the far pushed out
    f_tan = dvec2(u_tan_half) * (1.0lf + 4.0lf / dvec2(u_size));
    f_near = double(u_near_far.x) * (1.0lf - 1e-3lf);
    f_far = double(u_near_far.y) * (1.0lf + 1e-3lf);
    g_lo = dvec2(1e300lf); g_hi = dvec2(-1e300lf);
    g_dlo = 1e300lf; g_dhi = -1e300lf;
    g_full = false;

    make_bound(L);
    // the corners' outcodes: all inside the frustum, the bound's corners are the point set;
    // all outside one plane, the intersection is empty; else clip (most lights need not)
    uint out_all = 63u, out_any = 0u;
    // trips: 8
    for (int c = 0; c < 8; ++c) {
        dvec3 p = corner(c);
        uint code = 0u;
        // trips: 6
        for (int k = 0; k < 6; ++k) {
            dvec4 pl = plane(k);
            if (dot(pl.xyz, p) + pl.w > 0.0lf) code |= 1u << uint(k);
        }
        out_all &= code;
        out_any |= code;
    }
    if (out_any == 0u) {
        // trips: 8
        for (int c = 0; c < 8; ++c) add_point(corner(c));
    } else if (out_all == 0u) {
        for (int f = 0; f < 6; ++f) clip_face(f);
        for (int c = 0; c < 8; ++c) {
            double z = (c & 4) != 0 ? f_far : f_near;
            dvec3 p = dvec3(((c & 1) != 0 ? 1.0lf : -1.0lf) * f_tan.x * z,
                            ((c & 2) != 0 ? 1.0lf : -1.0lf) * f_tan.y * z, -z);
            if (inside_bound(p)) add_point(p);
        }
    }
    if (g_full) {
        g_lo = dvec2(-1e6lf); g_hi = dvec2(1e6lf);
        g_dlo = 0.0lf; g_dhi = 1e300lf;
    }

    // the bounding sphere's AABB (bounds[]: the culling sphere, margins included)
    dvec4 sph = dvec4(bounds[li].center_radius);
    double near_z = -f_near;
    dvec2 sx = sphere_axis(sph.x, sph.z, sph.w, near_z, double(u_tan_half.x));
    dvec2 sy = sphere_axis(sph.y, sph.z, sph.w, near_z, double(u_tan_half.y));
    dvec2 size = dvec2(u_size);
    double m = double(FPTL_PIXEL_MARGIN);
    dvec4 rect = dvec4(max(g_lo.x - m, (sx.x * 0.5lf + 0.5lf) * size.x - m),
                       min(g_hi.x + m, (sx.y * 0.5lf + 0.5lf) * size.x + m),
                       max(g_lo.y - m, (sy.x * 0.5lf + 0.5lf) * size.y - m),
                       min(g_hi.y + m, (sy.y * 0.5lf + 0.5lf) * size.y + m));
    dvec2 depth = dvec2(max(g_dlo, -sph.z - sph.w), min(g_dhi, -sph.z + sph.w));
    bool empty = !(rect.x <= rect.y && rect.z <= rect.w && depth.x <= depth.y);

    FptlAabb a;
    // float32, rounded outwards (the stored bounds stay conservative)
    a.rect = empty ? vec4(1e30, -1e30, 1e30, -1e30)
                   : vec4(clamp(rect - dvec4(1e-3lf, -1e-3lf, 1e-3lf, -1e-3lf), -1e30lf, 1e30lf));
    a.depth = empty ? vec2(1e30, -1e30)
                    : vec2(clamp(depth * dvec2(1.0lf - 1e-6lf, 1.0lf + 1e-6lf), 0.0lf, 1e30lf));
    a.light = li;
    a.pad = 0u;
    fptl_aabbs[k] = a;
}
