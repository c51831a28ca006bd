// A pixel of the frame as every pass that evaluates lights sees it: G-buffer fetch, the one
// light model (evaluate_light, the only place any technique decides "affects"), and the
// per-pixel counters of the dump contract.  The light-type code comes from the generated
// "features.glsl" (app.pipeline.features), so a scene compiles only the light types it has.
//
// Dispatch windows: a software rasterizer (llvmpipe) silently stops every loop of an
// invocation once their iterations together pass 65,535 (docs/platform.md "Platform facts").  So a pass
// may run as several dispatches, each evaluating the lights at positions [u_window.x,
// u_window.y) of the pixel's sequence (the order its loops meet lights in, counted by s.seq)
// and carrying the pixel's sums over from the previous dispatch: the same lights in the same
// order, so the same counts, hash and image as one dispatch.  One dispatch: (0, 0xFFFFFFFF).

layout(local_size_x = 8, local_size_y = 8) in;   // one emulated 64-lane wave

const uint LIGHT_RUN = 32u;   // lights a mask of evaluate_all_lights covers (one uint)

// the G-buffer at its units (app/pipeline/gbuffer.py TEXTURE_UNITS, via generated.glsl)
layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;  // xyz view-space position, w depth (0 = sky)
layout(binding = G_NORMAL_UNIT) uniform sampler2D g_normal;      // xyz view-space normal
layout(binding = G_ALBEDO_UNIT) uniform sampler2D g_albedo;

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };

uniform ivec2 u_size;
uniform uint u_light_count;
uniform uvec2 u_window;       // this dispatch's positions [x, y) of each pixel's sequence

// define: DEBUG_PIXEL
#if DEBUG_PIXEL
// The exactness check's explanation (app/exactness.py): the ids of the lights that affect
// one pixel, as this pass's loop met them.
layout(std430, binding = B_DEBUG_LIGHTS) buffer DebugLights { uint debug_count; uint debug_ids[]; };
uniform ivec2 u_debug_pixel;
#endif

// Dump contract: contrib_hash is the XOR over affecting lights of mix(id).
uint mix_hash(uint x) {
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}

struct PixelState {
    ivec2 pixel;
    bool inside;      // pixel within the image (the 8x8 groups overhang odd sizes)
    bool shading;     // inside and covered by geometry: shading runs
    vec3 P;           // view-space position, identical for every technique
    float depth;      // linear view depth
    vec3 N;
    vec3 albedo;
    float roughness;  // GGX roughness, 0 = matte (Lambert only)
    float metallic;
    vec3 radiance;
    uint evaluated;   // lights the loop evaluated
    uint count;       // evaluated lights that affect the pixel
    uint hash;
    uint nodes;       // tree nodes visited
    uint seq;         // position in the pixel's sequence of lights (dispatch windows)
    uint cell;        // the cell of the technique's structure it read (out_cell; 0: none)
};

#include "features.glsl"
#include "material.glsl"

PixelState load_pixel_at(ivec2 pixel) {
    PixelState s;
    s.pixel = pixel;
    s.inside = all(lessThan(s.pixel, u_size));
    vec4 pos = s.inside ? texelFetch(g_position, s.pixel, 0) : vec4(0.0);
    s.P = pos.xyz;
    s.depth = pos.w;
    s.shading = s.inside && pos.w > 0.0;
    vec4 n = s.inside ? texelFetch(g_normal, s.pixel, 0) : vec4(0.0, 0.0, 1.0, 0.0);
    vec4 a = s.inside ? texelFetch(g_albedo, s.pixel, 0) : vec4(0.0);
    s.N = n.xyz;
    s.roughness = n.w;
    s.albedo = a.rgb;
    s.metallic = a.a;
    s.radiance = vec3(0.0);
    s.evaluated = 0u; s.count = 0u; s.hash = 0u; s.nodes = 0u; s.seq = 0u; s.cell = 0u;
    return s;
}

// The part [a, b) of the next `count` positions of the pixel's sequence that lies in this
// dispatch's window; advances the sequence past them.
uvec2 window_part(inout PixelState s, uint count) {
    uint a = clamp(u_window.x, s.seq, s.seq + count) - s.seq;
    uint b = clamp(u_window.y, s.seq, s.seq + count) - s.seq;
    s.seq += count;
    return uvec2(a, b);
}

// The first dispatch of a pass counts the work that every window repeats (tree nodes).
bool first_window() { return u_window.x == 0u; }

// Whether light L (of shape `type`) affects the pixel: the only place any technique decides
// "affects".  A per-type loop passes its constant type and compiles that shape's code alone.
// priced: test
bool light_affects_pixel(PixelState s, GpuLight L, uint type) {
    precise vec3 d = s.P - L.pos_radius.xyz;
    precise float d2 = dot(d, d);
    return light_affects_as(L, d, d2, type);
}

// What an affecting light adds to the pixel: its count, hash and radiance.
// priced: shade
void shade_affecting(inout PixelState s, GpuLight L, uint type) {
#if DEBUG_PIXEL
    if (s.pixel == u_debug_pixel) {
        uint k = atomicAdd(debug_count, 1u);
        if (k < uint(debug_ids.length())) debug_ids[k] = L.id_type.x;
    }
#endif
    precise vec3 d = s.P - L.pos_radius.xyz;
    precise float d2 = dot(d, d);
    s.count++;
    s.hash ^= mix_hash(L.id_type.x);
    vec3 l;
    vec3 arriving = light_radiance_as(L, d, d2, s.N, l, type);
    s.radiance += arriving * surface_response(s.N, normalize(-s.P), l, s.albedo, s.roughness, s.metallic);
}

// Evaluate one light of shape `type` for the pixel.
void evaluate_light_as(inout PixelState s, GpuLight L, uint type) {
    s.evaluated++;
    if (light_affects_pixel(s, L, type)) shade_affecting(s, L, type);
}

// Evaluate a light of any shape compiled in (one type test per shape but the last).
void evaluate_light(inout PixelState s, GpuLight L) { evaluate_light_as(s, L, L.id_type.y); }

// The affects mask of the n <= 32 lights from position `first` of lights[] (bit k: light
// first + k), each counted as evaluated.
uint affecting_mask(inout PixelState s, uint first, uint n) {
    uint mask = 0u;
    // priced: mask_light
    for (uint k = 0u; k < n; ++k) {
        GpuLight L = lights[first + k];
        s.evaluated++;
        if (light_affects_pixel(s, L, L.id_type.y)) mask |= 1u << k;
    }
    return mask;
}

// Every visible light in this dispatch's window (brute, and tiles whose list overflowed), in
// two phases per run of LIGHT_RUN lights: the affects mask, then the shading of its set bits
// in order (the same lights in the same order as one evaluate_light each: the same count,
// hash and image).  Why: a software rasterizer runs an if's body masked for the whole SIMD
// vector whenever the if is reached (llvmpipe: no branch), so a per-light `if (affects)`
// paid the shading code at every (pixel, light) pair; a loop exits when no lane is left, so
// the set-bit loop pays it only as often as the busiest lane has lights (brute 3.7x faster
// on the arena at 8,192 lights).  On a GPU the set-bit loop packs the lanes of a wave onto
// their own lights instead of running one light's shading for any lane it affects
// (app/model/waves replays both loops).  Loop budget: up to 2 + 3/32 iterations a light
// (cpu_prep/limits.py DISPATCH_WINDOW).
void evaluate_all_lights(inout PixelState s) {
    uvec2 w = window_part(s, u_light_count);
    for (uint first = w.x; first < w.y; first += LIGHT_RUN) {
        uint mask = affecting_mask(s, first, min(LIGHT_RUN, w.y - first));
        // priced: set_bit
        while (mask != 0u) {
            uint i = first + uint(findLSB(mask));
            mask &= mask - 1u;
            GpuLight L = lights[i];
            shade_affecting(s, L, L.id_type.y);
        }
    }
}
