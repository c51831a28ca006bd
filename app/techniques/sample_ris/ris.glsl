// sample-ris's reservoirs (Bitterli et al. 2020, "Spatiotemporal reservoir resampling for
// real-time ray tracing with dynamic direct lighting"): one a pixel for the round
// u_reservoir of S, written by one pass (ris_out) and read by the next (ris_in).
//   Reservoir {light, M, evaluated, W, p_hat, f_r, f_g, f_b}   (ris_structs.glsl, from
//   sample_ris.RESERVOIR): the kept light's index in lights[] (RIS_NO_LIGHT: none), the
//   candidates it stands for, the pixel's evaluations so far this round, its unbiased
//   contribution weight W, and p-hat and f of the kept light at this pixel.
// Needs sampling.glsl (the pixel's stream).
#include "ris_structs.glsl"

// (a pass binds those of the two it declares; the renderer drops the other's block)
layout(std430, binding = B_RIS_IN) readonly buffer RisIn { Reservoir ris_in[]; };
layout(std430, binding = B_RIS_OUT) writeonly buffer RisOut { Reservoir ris_out[]; };

uniform uint u_reservoir;      // this round's reservoir, 0 .. S - 1

// The target p-hat: the luminance of the unshadowed contribution (Rec. 709 weights, those
// of app.sampling_check, which judges the estimate's luminance).
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// One target evaluation: f of light L at the pixel, unshadowed, zero outside its volume.
vec3 target_contribution(inout PixelState s, GpuLight L) { return light_contribution(s, L, L.id_type.y); }

uint pixel_index(ivec2 p) { return uint(p.y) * uint(u_size.x) + uint(p.x); }

Reservoir empty_reservoir() {
    Reservoir r;
    r.light = RIS_NO_LIGHT; r.M = 0u; r.evaluated = 0u;
    r.W = 0.0; r.p_hat = 0.0; r.f_r = 0.0; r.f_g = 0.0; r.f_b = 0.0;
    return r;
}

// Keep light `light` (contribution f at this pixel) as the reservoir's sample.
void keep(inout Reservoir r, uint light, vec3 f) {
    r.light = light;
    r.p_hat = luminance(f);
    r.f_r = f.r; r.f_g = f.g; r.f_b = f.b;
}

vec3 kept_contribution(Reservoir r) { return vec3(r.f_r, r.f_g, r.f_b); }

// Weighted reservoir sampling's update (the paper's Algorithm 2): the stream's draw u keeps
// the candidate of weight w with probability w / wsum (wsum including w).  One draw a
// candidate, zero weights included, so a round's stream advances the same in every pixel.
bool accept(inout float wsum, float w, inout uint stream) {
    wsum += w;
    float u = next_unit(stream);
    return w > 0.0 && u * wsum < w;
}

// W = (1 / p-hat(y)) (1 / m) wsum; 0 with no sample kept (p-hat 0).
float contribution_weight(float wsum, float m, float p_hat) {
    return p_hat > 0.0 && m > 0.0 ? wsum / (m * p_hat) : 0.0;
}

// This round's stream of the pixel: the pixel's stream (sampling.glsl) hashed with the round,
// so that the S reservoirs draw independently.
uint round_stream(PixelState s, uint salt) {
    return pcg_hash(pixel_stream(s) ^ pcg_hash(u_reservoir * 0x9E3779B9u + salt));
}
