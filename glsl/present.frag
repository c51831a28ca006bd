#version 430
// The window's present and HUD passes (app/window/passes.py): draws one of the views
// straight from the frame's storage buffers (no CPU readback), or, with HUD = 1, blits the
// HUD text texture (texture unit HUD_UNIT).  The buffers are bound where the pass declares
// them (B_<SLOT>, numbered by the renderer):
//   out_color[y * W + x]   vec4 linear radiance        (GL row order, row 0 = bottom)
//   out_stats[y * W + x]   PixelStats: evaluated, contrib_count, contrib_hash, nodes
//   wave_stats[group]      WaveStats: iterations, case_bits (1 list, 2 tree, 3 mixed, 0 empty)
//   view_stats             ViewStats: frame sums of present_stats.comp (max_evaluated: heat scale)
// define: HUD HUD_UNIT
#include "generated.glsl"

in vec2 v_uv;
out vec4 frag;

#if HUD
layout(binding = HUD_UNIT) uniform sampler2D u_hud;
void main() {
    frag = texture(u_hud, vec2(v_uv.x, 1.0 - v_uv.y));   // the PIL image has row 0 at the top
}
#else

#define VIEW_SHADED 0
#define VIEW_HEAT 1
#define VIEW_CLASSES 2
#define VIEW_TILES 3
#define VIEW_SLICES 4

layout(binding = 0) uniform sampler2D g_position;   // w = linear view depth, 0 = sky
layout(std430, binding = B_OUT_COLOR) readonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_OUT_STATS) readonly buffer OutStats { PixelStats out_stats[]; };
layout(std430, binding = B_WAVE_STATS) readonly buffer WaveStatsBuffer { WaveStats wave_stats[]; };
layout(std430, binding = B_VIEW_STATS) readonly buffer ViewStatsBuffer { ViewStats view_stats; };

uniform ivec2 u_size;          // render size = viewport size
uniform int u_view;
uniform int u_tile;            // the technique's tile size in pixels (tiles start bottom-left);
                               // 0: it has no tiles, the tiles view shows the shaded image
uniform int u_slices;          // its depth slices (tree paper listing 4, scale corrected);
                               // <= 1: none, the slices view shows the shaded image
uniform float u_slice_scale;
uniform float u_slice_bias;
uniform float u_heat_max;      // > 0: fixed heat scale; 0: this frame's max

// Same as app.images.tonemap: Reinhard x / (1 + x), gamma 1/2.2.
vec3 tonemap(vec3 x) {
    x = max(x, vec3(0.0));
    return pow(x / (1.0 + x), vec3(1.0 / 2.2));
}

// Turbo colour ramp (Mikhailov 2019, polynomial fit), t in [0, 1].
vec3 turbo(float t) {
    t = clamp(t, 0.0, 1.0);
    const vec4 kr = vec4(0.13572138, 4.61539260, -42.66032258, 132.13108234);
    const vec4 kg = vec4(0.09140261, 2.19418839, 4.84296658, -14.18503333);
    const vec4 kb = vec4(0.10667330, 12.64194608, -60.58204836, 110.36276771);
    const vec2 kr2 = vec2(-152.94239396, 59.28637943);
    const vec2 kg2 = vec2(4.27729857, 2.82956604);
    const vec2 kb2 = vec2(-89.90310912, 27.34824973);
    vec4 v4 = vec4(1.0, t, t * t, t * t * t);
    vec2 v2 = v4.zw * v4.z;
    return vec3(dot(v4, kr) + dot(v2, kr2), dot(v4, kg) + dot(v2, kg2), dot(v4, kb) + dot(v2, kb2));
}

// Tree paper listing 4 (cpu_prep.grid: scale = (S - 1) / (logMax - logMin)).
int slice_of(float depth) {
    float s = max(log(depth) * u_slice_scale + u_slice_bias, 0.0);
    return min(int(s), u_slices - 1);
}

vec3 slice_color(int s) {
    // alternating hues so neighbouring slices differ; slice 0 (near slice) grey
    if (s == 0) return vec3(0.55);
    float h = fract(float(s) * 0.381966);
    return clamp(abs(fract(h + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0) * 0.8 + 0.2;
}

const vec3 CASE_COLORS[4] = vec3[4](vec3(40.0, 40.0, 40.0) / 255.0, vec3(60.0, 110.0, 230.0) / 255.0,
                                    vec3(60.0, 200.0, 90.0) / 255.0, vec3(245.0) / 255.0);

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    if (any(greaterThanEqual(p, u_size))) { frag = vec4(0.0, 0.0, 0.0, 1.0); return; }
    uint i = uint(p.y * u_size.x + p.x);
    vec3 shaded = tonemap(out_color[i].rgb);
    float depth = texelFetch(g_position, p, 0).w;
    vec3 c = shaded;
    if (u_view == VIEW_HEAT) {
        float vmax = u_heat_max > 0.0 ? u_heat_max : max(float(view_stats.max_evaluated), 1.0);
        uint e = out_stats[i].evaluated;
        // log ramp: a few hot pixels (near lights) do not flatten the rest of the frame
        c = depth > 0.0 ? turbo(log2(1.0 + float(e)) / log2(1.0 + vmax)) : vec3(0.0);
        if (depth > 0.0 && e == 0u) c = vec3(0.07);
    } else if (u_view == VIEW_CLASSES) {
        int gw = (u_size.x + 7) / 8;
        uint bits = wave_stats[(p.y / 8) * gw + p.x / 8].case_bits & 3u;
        c = mix(CASE_COLORS[bits], shaded, 0.2);
    } else if (u_view == VIEW_TILES && u_tile > 0) {
        ivec2 q = p % u_tile;
        bool edge = q.x == 0 || q.y == 0;
        c = edge ? mix(shaded, vec3(1.0, 0.85, 0.2), 0.7) : shaded;
    } else if (u_view == VIEW_SLICES && u_slices > 1) {
        if (depth > 0.0) {
            int s = slice_of(depth);
            float lum = dot(shaded, vec3(0.2126, 0.7152, 0.0722));
            c = slice_color(s) * (0.45 + 0.55 * min(lum * 3.0, 1.0));
        } else {
            c = vec3(0.0);
        }
    }
    frag = vec4(c, 1.0);
}
#endif
