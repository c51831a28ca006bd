// Shared by every shading pass: G-buffer fetch, the one light model, the per-pixel counters
// of the dump contract, and output.  The light-type code comes from the generated
// "features.glsl" (app.features), so a scene compiles only the light types it contains.
// define: LIGHTS_DUPLICATED

layout(local_size_x = 8, local_size_y = 8) in;   // one emulated 64-lane wave

layout(binding = 0) uniform sampler2D g_position;  // xyz view-space position, w depth (0 = sky)
layout(binding = 1) uniform sampler2D g_normal;    // xyz view-space normal
layout(binding = 2) uniform sampler2D g_albedo;

layout(std430, binding = B_LIGHTS) readonly buffer LightBuffer { GpuLight lights[]; };
layout(std430, binding = B_OUT_COLOR) writeonly buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_OUT_STATS) writeonly buffer OutStats { uvec4 out_stats[]; };
layout(std430, binding = B_WAVE_STATS) buffer WaveStats { uvec4 wave_stats[]; };  // zeroed each frame

uniform ivec2 u_size;
uniform uint u_light_count;

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
    vec3 radiance;
    uint evaluated;   // lights the loop evaluated
    uint count;       // evaluated lights that affect the pixel
    uint hash;
    uint nodes;       // tree nodes visited
};

#include "features.glsl"

PixelState load_pixel_at(ivec2 pixel) {
    PixelState s;
    s.pixel = pixel;
    s.inside = all(lessThan(s.pixel, u_size));
    vec4 pos = s.inside ? texelFetch(g_position, s.pixel, 0) : vec4(0.0);
    s.P = pos.xyz;
    s.depth = pos.w;
    s.shading = s.inside && pos.w > 0.0;
    s.N = s.inside ? texelFetch(g_normal, s.pixel, 0).xyz : vec3(0.0, 0.0, 1.0);
    s.albedo = s.inside ? texelFetch(g_albedo, s.pixel, 0).rgb : vec3(0.0);
    s.radiance = vec3(0.0);
    s.evaluated = 0u; s.count = 0u; s.hash = 0u; s.nodes = 0u;
    return s;
}

PixelState load_pixel() { return load_pixel_at(ivec2(gl_GlobalInvocationID.xy)); }

// Evaluate one light for the pixel: the only place any technique decides "affects".
void evaluate_light(inout PixelState s, GpuLight L) {
    s.evaluated++;
    precise vec3 d = s.P - L.pos_radius.xyz;
    precise float d2 = dot(d, d);
    if (light_affects(L, d, d2)) {
        s.count++;
        s.hash ^= mix_hash(L.id_type.x);
        s.radiance += light_radiance(L, d, d2, s.N) * s.albedo;
    }
}

void store_pixel(PixelState s) {
    if (!s.inside) return;
    uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
    out_color[i] = vec4(s.radiance, 1.0);
    out_stats[i] = uvec4(s.evaluated, s.count, s.hash, s.nodes);
}

uint group_index() {
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

// Wave statistics, per 8x8 group: the longest lane's loop length (the wave's scalar
// iterations) and which traversal case ran (bit 0 list, bit 1 tree; both = mixed; the
// hybrid adds bit 2 when the group's tree was read from shared memory).
// Global atomics, not a group reduction: barriers are what the emulation pays most for.
void write_wave_stats(uint iterations, uint case_bits) {
    uint g = group_index();
    atomicMax(wave_stats[g].x, iterations);
    if (case_bits != 0u) atomicOr(wave_stats[g].y, case_bits);
}
