#version 450
// raster (Drobot 2017, rasterization based culling): one light's proxy mesh, placed and
// scaled in view space from the light (GpuLight) and its proxy record (RasterProxy, built by
// cpu_prep/raster_proxies.py; docs/raster.md gives the exactness argument).  Instanced: the
// instance is the light order[u_first + u_instance + gl_InstanceID].
//   sphere   in_vertex.xyz on the unit icosphere                 p + radius * v
//   cone     (cos phi, sin phi, t, apex): cap at polar t * cap_angle, or the apex moved back
//   capsule  (unit xyz, end): hemisphere vertex around end * length / 2
//   box      corners (+-1): right, up' = right x dir, dir times extents + margin
// u_mode (raster_mark.frag / raster_cluster.frag) only picks the depth bias's direction here.
// Depth is the technique's own (raster_fill.frag): reversed, far plane at infinity, window
// depth = near / view depth, affine in screen space and well conditioned in float32 (the
// G-buffer's standard depth is not: llvmpipe's interpolation on huge triangles errs by 2e-4
// near 1.0).  The proxy's window depth moves towards passing the hardware test, relatively
// (DEPTH_BIAS_REL) and absolutely (DEPTH_BIAS_ABS): nearer for front faces (GREATER_EQUAL),
// farther for back faces (LESS_EQUAL); the shader redoes the test exactly in linear depth.
// Only the near plane clips (z_clip = 2 n' - w: z_ndc <= 1 iff depth >= n').  u_ndc maps the
// frame's NDC onto a half-resolution target whose pixels cover 2x2 full-resolution ones.
#include "generated.glsl"
#include "raster_structs.glsl"

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = B_RASTER_PROXIES) readonly buffer Proxies { RasterProxy proxies[]; };
layout(std430, binding = B_RASTER_ORDER) readonly buffer Order { uint order[]; };

uniform mat4 u_clip_from_view;
uniform float u_near;
uniform int u_shape;          // PROXY_*
uniform uint u_first;         // this group's first entry of order[]
uniform int u_instance;       // per-instance stencil sequences draw one instance at a time
uniform int u_mode;           // RASTER_MODE_* (raster.MODES)
uniform int u_step;           // stencil sequence: 0 front faces, 1 back faces
uniform vec4 u_ndc;           // x, y scale and (times w) offset of the NDC

// define: RASTER_TRI_BOUNDS
in vec4 in_vertex;
flat out uint v_light;
#if RASTER_TRI_BOUNDS
in vec4 in_vertex1;           // the triangle's other two corners (cluster rasterizer)
in vec4 in_vertex2;
flat out vec2 v_tri_depth;
#endif

// (e1, e2) with (e1, e2, f) right-handed orthonormal (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited"); raster.basis() is the same on the CPU.
void basis(vec3 f, out vec3 e1, out vec3 e2) {
    float s = f.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + f.z);
    float b = f.x * f.y * a;
    e1 = vec3(1.0 + s * f.x * f.x * a, s * b, -s * f.x);
    e2 = vec3(b, s + f.y * f.y * a, -f.y);
}

// One mesh vertex of light L's proxy, in view space.
vec3 place(vec4 a, GpuLight L, RasterProxy pr) {
    vec3 p = L.pos_radius.xyz;
    vec3 f = L.dir_cos_outer.xyz;
    if (u_shape == PROXY_SPHERE) return p + pr.radius * a.xyz;
    if (u_shape == PROXY_BOX) {
        vec3 r = L.right.xyz;
        vec3 e = L.extent_length.xyz + pr.margin;
        return p + a.x * e.x * r + a.y * e.y * cross(r, f) + a.z * e.z * f;
    }
    vec3 e1, e2;
    basis(f, e1, e2);
    if (u_shape == PROXY_CAPSULE)
        return p + f * (a.w * 0.5 * L.extent_length.w) + pr.radius * (a.x * e1 + a.y * e2 + a.z * f);
    if (a.w > 0.5) return p - f * pr.apex_back;        // the cone's apex, moved back
    float th = a.z * pr.cap_angle;
    return p + pr.radius * (sin(th) * (a.x * e1 + a.y * e2) + cos(th) * f);
}

// priced: vertex
void main() {
    uint li = order[u_first + uint(u_instance) + uint(gl_InstanceID)];
    GpuLight L = lights[li];
    RasterProxy pr = proxies[li];
    vec3 v = place(in_vertex, L, pr);
#if RASTER_TRI_BOUNDS
    // the slides' vertex depths of the triangle (GetVertexParameterP0..2): every vertex of a
    // triangle computes all three corners, so the flat value is the same whichever provokes
    float d1 = -place(in_vertex1, L, pr).z, d2 = -place(in_vertex2, L, pr).z;
    v_tri_depth = vec2(min(-v.z, min(d1, d2)), max(-v.z, max(d1, d2)));
#endif
    v_light = li;
    vec4 clip = u_clip_from_view * vec4(v, 1.0);
    bool back = u_mode == RASTER_MODE_BACK || (u_mode == RASTER_MODE_STENCIL && u_step == 1);
    // window depth n (1 +- rel) / d +- abs:  z_ndc = 2 window - 1, times w = d
    float s = back ? -1.0 : 1.0;
    clip.z = 2.0 * u_near * (1.0 + s * DEPTH_BIAS_REL) + clip.w * (2.0 * s * DEPTH_BIAS_ABS - 1.0);
    clip.xy = clip.xy * u_ndc.xy + clip.w * u_ndc.zw;
    gl_Position = clip;
}
