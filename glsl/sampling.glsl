// Light sampling (the sampler techniques, app/techniques/sample_*): a pixel's random stream,
// a light's weighted contribution, and the two stores of a sampling frame.
//
// A sampling pass writes the pixel's estimate (radiance), its evaluations and its cell; its
// support pass (figures only, untimed) then writes contrib_count and contrib_hash of every
// light the pixel's draw can reach, evaluated: that set must equal brute's at every pixel
// (each affecting light has a nonzero probability there), the exactness check's part of a
// sampler; its estimate is held to brute statistically (app/sampling_check.py).
// define: SAMPLE_MASS_BITS
// define: SAMPLE_FAULT

uniform uint u_samples;        // S, the samples a shading pixel
uniform uint u_sample_seed;
uniform uint u_sample_frame;

// PCG's RXS-M-XS output of a 32-bit LCG state (O'Neill 2014; Jarzynski & Olano 2020,
// "Hash functions for GPU rendering": pcg).
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The pixel's stream of (seed, frame, pixel): one state, advanced a draw at a time.
uint pixel_stream(PixelState s) {
    uint p = uint(s.pixel.y) * uint(u_size.x) + uint(s.pixel.x);
    return pcg_hash(p ^ pcg_hash(u_sample_seed ^ pcg_hash(u_sample_frame + 0x9E3779B9u)));
}

uint next_random(inout uint state) {
    state = state * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// u uniform in [0, 2^SAMPLE_MASS_BITS): compared with the integer CDF words (cpu_prep.sampling)
uint next_mass(inout uint state) { return next_random(state) >> (32u - uint(SAMPLE_MASS_BITS)); }

// u uniform in [0, 1) with 24 bits
float next_unit(inout uint state) { return float(next_random(state) >> 8u) * (1.0 / 16777216.0); }

// A probability of mass m: m / 2^SAMPLE_MASS_BITS (exact up to float's 24-bit rounding of m).
float mass_probability(uint m) { return float(m) * exp2(-float(SAMPLE_MASS_BITS)); }

// What an affecting light adds (pixel.glsl shade_affecting's radiance, without its count).
// priced: shade
vec3 affecting_radiance(PixelState s, GpuLight L, uint type) {
    precise vec3 d = s.P - L.pos_radius.xyz;
    precise float d2 = dot(d, d);
    vec3 l;
    vec3 arriving = light_radiance_as(L, d, d2, s.N, l, type);
    return arriving * surface_response(s.N, normalize(-s.P), l, s.albedo, s.roughness, s.metallic);
}

// What light L (of shape `type`) adds to the pixel, zero outside its volume: one evaluation,
// its affects test the one of every technique (pixel.glsl light_affects_pixel).
vec3 light_contribution(inout PixelState s, GpuLight L, uint type) {
    s.evaluated++;
    if (!light_affects_pixel(s, L, type)) return vec3(0.0);
    return affecting_radiance(s, L, type);
}

// One sample's contribution f / p.  SAMPLE_FAULT (the statistical check's negative
// controls, tests/app/test_sampling_check.py; 0 in every real frame): 1 drops the 1/p
// weight, 2 weights by a pdf that is not normalised (the mass in units of 2^-16).
vec3 weighted(vec3 f, float p) {
#if defined(SAMPLE_FAULT) && SAMPLE_FAULT == 1
    return f;
#elif defined(SAMPLE_FAULT) && SAMPLE_FAULT == 2
    return f / (p * 65536.0);
#else
    return f / p;
#endif
}

// The sampling pass's store: the estimate, the evaluations, tree nodes and cell (the support
// pass writes the light set's count and hash).
void store_estimate(PixelState s) {
    if (!s.inside) return;
    uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
    out_color[i] = vec4(s.radiance, 1.0);
    out_stats[i].evaluated = s.evaluated;
    out_stats[i].nodes = s.nodes;
    out_cell[i] = s.cell;
}

// The support pass's store: count and hash of the lights the pixel's draw can reach that
// affect it.
void store_support(PixelState s) {
    if (!s.inside) return;
    uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
    out_stats[i].contrib_count = s.count;
    out_stats[i].contrib_hash = s.hash;
}
