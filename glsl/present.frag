#version 430
// The window's present pass (app/window/passes.py): one of the views, drawn straight from
// the frame's storage buffers (no CPU readback), with the debug draws of the cursor; or,
// with STASH = 1, a copy of this frame's radiance and per-pixel counters into two textures
// (the reference's frame for the diff view, the second technique's for the split view).
// The buffers are bound where the pass declares them (B_<SLOT>, numbered by the renderer):
//   out_color[y * W + x]   vec4 linear radiance        (GL row order, row 0 = bottom)
//   out_stats[y * W + x]   PixelStats: evaluated, contrib_count, contrib_hash, nodes
//   wave_stats[group]      WaveStats: iterations, case_bits (CASE_*: list, tree, mixed; 0 empty)
// View ids (VIEW_*) and texture units (*_UNIT) are defines from app/window/views.py and
// passes.py; the display and heat functions are present_common.glsl (app/images.py's twins).
// define: STASH VIEW_SHADED VIEW_HEAT VIEW_TILES VIEW_SLICES VIEW_CLASSES VIEW_DIFF VIEW_SPLIT
// define: REF_COLOR_UNIT REF_STATS_UNIT SPLIT_COLOR_UNIT SPLIT_STATS_UNIT MAP_UNIT VIEW_MAPS
#include "generated.glsl"
#include "present_common.glsl"

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;   // xyz view space, w = linear depth, 0 = sky
layout(binding = G_ALBEDO_UNIT) uniform sampler2D g_albedo;
layout(std430, binding = B_OUT_COLOR) readonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_OUT_STATS) readonly buffer OutStats { PixelStats out_stats[]; };

uniform ivec2 u_size;          // render size (the buffers' and the G-buffer's)

#if STASH
layout(location = 0) out vec4 o_color;
layout(location = 1) out uvec4 o_stats;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    uint i = uint(p.y * u_size.x + p.x);
    PixelStats st = out_stats[i];
    o_color = vec4(out_color[i].rgb, 1.0);
    o_stats = uvec4(st.evaluated, st.contrib_count, st.contrib_hash, st.nodes);
}
#else

layout(std430, binding = B_WAVE_STATS) readonly buffer WaveStatsBuffer { WaveStats wave_stats[]; };
layout(binding = REF_STATS_UNIT) uniform usampler2D u_ref_stats;
layout(binding = SPLIT_COLOR_UNIT) uniform sampler2D u_split_color;
layout(binding = SPLIT_STATS_UNIT) uniform usampler2D u_split_stats;
layout(binding = MAP_UNIT) uniform sampler2D u_map;        // maps view: a count per pixel
out vec4 frag;

uniform ivec2 u_viewport;      // the target's size: the render is scaled to it
uniform int u_view;
uniform float u_exposure;
uniform float u_ambient;
uniform float u_heat_max;      // top of the heat scale (the frame's max or a fixed number)
uniform int u_heat_of;         // 0 lights evaluated, 1 exact lights (contrib_count)
uniform int u_heat_overlay;    // 1: the heat map over the shaded image
uniform int u_tile;            // the technique's tile size in pixels (tiles start bottom-left)
uniform int u_ref_valid;       // diff: the reference's counters are this frame's
uniform int u_split_x;         // split: columns >= u_split_x show the second technique
uniform int u_split_view;      // split: each half as VIEW_SHADED or VIEW_HEAT
uniform ivec4 u_cursor_tile;   // inspect: the tile under the cursor (x0, y0, x1, y1), x1 < 0 none
uniform ivec2 u_cursor;        // inspect: the cursor's pixel (-1: none)
uniform vec4 u_light_sphere;   // inspect: bounding sphere (view space) of the picked light, w <= 0 none
uniform vec2 u_tan_half;       // tan of half the field of view, x and y
uniform float u_map_max;       // maps view: top of its heat scale

// the technique's depth slices: u_slices, slice_of
#include "slices.glsl"

vec3 slice_color(int s) {
    // alternating hues so neighbouring slices differ; slice 0 (near slice) grey
    if (s == 0) return vec3(0.55);
    float h = fract(float(s) * 0.381966);
    return clamp(abs(fract(h + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0) * 0.8 + 0.2;
}

const vec3 CASE_COLORS[4] = vec3[4](vec3(40.0, 40.0, 40.0) / 255.0, vec3(60.0, 110.0, 230.0) / 255.0,
                                    vec3(60.0, 200.0, 90.0) / 255.0, vec3(245.0) / 255.0);
const vec3 MARK = vec3(255.0, 40.0, 40.0) / 255.0;      // app/exactness.py MARK
const vec3 TILE_LINE = vec3(1.0, 0.85, 0.2);
const vec3 CURSOR = vec3(0.2, 0.95, 1.0);
const vec3 SPHERE = vec3(1.0, 0.55, 0.1);

vec3 heat_of(uvec4 st, float vmax, bool covered) {
    return heat_color(u_heat_of == 1 ? st.y : st.x, vmax, covered);
}

vec3 heat_view(vec3 shaded, uvec4 st, float vmax, bool covered) {
    vec3 h = heat_of(st, vmax, covered);
    if (u_heat_overlay == 0) return h;
    uint n = u_heat_of == 1 ? st.y : st.x;
    return (covered && n > 0u) ? mix(shaded, h, HEAT_OVERLAY_ALPHA) : shaded;
}

uvec4 stats_at(uint i) {
    PixelStats ps = out_stats[i];
    return uvec4(ps.evaluated, ps.contrib_count, ps.contrib_hash, ps.nodes);
}

void main() {
    ivec2 p = ivec2(floor(gl_FragCoord.xy * vec2(u_size) / vec2(u_viewport)));
    p = min(p, u_size - 1);
    uint i = uint(p.y * u_size.x + p.x);
    vec4 pos = texelFetch(g_position, p, 0);
    bool covered = pos.w > 0.0;
    // what a view does not show is not read (a software rasterizer pays for every load)
    vec3 albedo = u_ambient > 0.0 ? texelFetch(g_albedo, p, 0).rgb : vec3(0.0);
    bool plain_heat = u_view == VIEW_HEAT && u_heat_overlay == 0;
    vec3 shaded = plain_heat ? vec3(0.0) : display(out_color[i].rgb, albedo, u_exposure, u_ambient);
    vec3 c = shaded;
    if (u_view == VIEW_HEAT) {
        c = heat_view(shaded, stats_at(i), u_heat_max, covered);
    } else if (u_view == VIEW_CLASSES) {
        int gw = (u_size.x + 7) / 8;
        uint bits = wave_stats[(p.y / 8) * gw + p.x / 8].case_bits & CASE_MIXED;
        c = mix(CASE_COLORS[bits], shaded, 0.2);
    } else if (u_view == VIEW_TILES && u_tile > 0) {
        ivec2 q = p % u_tile;
        c = (q.x == 0 || q.y == 0) ? mix(shaded, TILE_LINE, 0.7) : shaded;
    } else if (u_view == VIEW_SLICES && u_slices > 1) {
        float lum = dot(shaded, vec3(0.2126, 0.7152, 0.0722));
        c = covered ? slice_color(int(slice_of(pos.w))) * (0.45 + 0.55 * min(lum * 3.0, 1.0)) : vec3(0.0);
    } else if (u_view == VIEW_DIFF) {
        vec3 grey = vec3(dot(shaded, vec3(1.0 / 3.0)) * 0.5);
        if (u_ref_valid == 0) {
            c = grey;                       // the reference is not this frame's yet
        } else {
            uvec4 st = stats_at(i);
            uvec4 r = texelFetch(u_ref_stats, p, 0);
            c = (r.y != st.y || r.z != st.z) ? MARK : grey;
        }
    } else if (u_view == VIEW_MAPS) {
        c = heat_color(uint(texelFetch(u_map, p, 0).r + 0.5), u_map_max, true);
    } else if (u_view == VIEW_SPLIT) {
        bool right = p.x >= u_split_x;
        uvec4 st = uvec4(0u);
        if (right) {
            st = texelFetch(u_split_stats, p, 0);
            shaded = display(texelFetch(u_split_color, p, 0).rgb, albedo, u_exposure, u_ambient);
        } else if (u_split_view == VIEW_HEAT) {
            st = stats_at(i);
        }
        c = u_split_view == VIEW_HEAT ? heat_view(shaded, st, u_heat_max, covered)
                                      : shaded;
        if (p.x == u_split_x || p.x == u_split_x - 1) c = vec3(1.0);
    }

    // ---- inspect: the picked light's bounding sphere, the tile and pixel under the cursor
    if (u_light_sphere.w > 0.0) {
        vec3 centre = u_light_sphere.xyz;
        float r = u_light_sphere.w;
        if (covered && distance(pos.xyz, centre) < r) c = mix(c, SPHERE, 0.35);
        vec2 ndc = (vec2(p) + 0.5) / vec2(u_size) * 2.0 - 1.0;
        vec3 ray = normalize(vec3(ndc * u_tan_half, -1.0));
        float along = dot(centre, ray);
        if (along > 0.0) {
            float off = length(centre - along * ray);
            float px = along * 2.0 * u_tan_half.y / float(u_size.y);   // one pixel at that depth
            // the silhouette: solid where in front of the geometry, faint behind it
            bool front = !covered || pos.w >= along * -ray.z;
            if (abs(off - r) < 0.9 * px) c = front ? SPHERE : mix(c, SPHERE, 0.5);
        }
    }
    if (u_cursor_tile.z >= 0) {
        bool inside = all(greaterThanEqual(p, u_cursor_tile.xy)) && all(lessThan(p, u_cursor_tile.zw));
        bool edge = p.x == u_cursor_tile.x || p.y == u_cursor_tile.y ||
                    p.x == u_cursor_tile.z - 1 || p.y == u_cursor_tile.w - 1;
        if (inside && edge) c = CURSOR;
    }
    if (u_cursor.x >= 0) {
        ivec2 d = abs(p - u_cursor);
        if ((d.x == 0 && d.y >= 2 && d.y <= 5) || (d.y == 0 && d.x >= 2 && d.x <= 5)) c = CURSOR;
    }
    frag = vec4(c, 1.0);
}
#endif
