#version 430
// sample-ris, spatial reuse (Bitterli et al. 2020, its spatial pass): each pixel's reservoir
// combined with those of k neighbours drawn uniformly in a disk of u_reuse_radius pixels,
// neighbours whose normal or depth differs too much skipped (the paper's heuristic),
//   biased    Algorithm 4: W = (1 / p-hat_q(y)) (1 / sum M) wsum
//   unbiased  Algorithm 6: 1 / Z in its place, Z the M of the combined pixels (this one
//             included) whose p-hat of y is > 0: p-hat of y evaluated at each neighbour
// each neighbour's sample weighted p-hat_q(y_i) W_i M_i, p-hat_q(y_i) evaluated here (one
// light evaluation; y_i need not be in this pixel's cell: p-hat is defined for any light).
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "sampling.glsl"
#include "ris.glsl"

uniform uint u_neighbours;     // k
uniform float u_reuse_radius;  // pixels
uniform uint u_unbiased;       // 1: Algorithm 6, 0: Algorithm 4

// The paper's similarity test: normals within 25 degrees, view depths within 10%.
const float SIMILAR_COS = 0.90630779;   // cos(25 degrees)
const float SIMILAR_DEPTH = 0.1;

// The next neighbour of the disk: (its pixel, whether it is in the image, shaded and similar).
bool next_neighbour(PixelState s, inout uint stream, out PixelState n) {
    float r = u_reuse_radius * sqrt(next_unit(stream));
    float a = 6.28318531 * next_unit(stream);
    ivec2 p = s.pixel + ivec2(round(vec2(cos(a), sin(a)) * r));
    bool image = all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, u_size));
    n = load_pixel_at(image ? p : s.pixel);
    return image && n.shading && dot(n.N, s.N) >= SIMILAR_COS
        && abs(n.depth - s.depth) <= SIMILAR_DEPTH * s.depth;
}

// Algorithm 6's Z: the M of the combined pixels whose p-hat of light y is > 0, the
// neighbours drawn again from the same stream; k evaluations at most.
float unbiased_z(inout PixelState s, Reservoir own, uint light, uint stream) {
    float z = float(own.M);                       // p-hat_q(y) > 0: y was kept
    GpuLight L = lights[light];
    for (uint k = 0u; k < u_neighbours; ++k) {
        PixelState n;
        if (!next_neighbour(s, stream, n)) continue;
        uint m = ris_in[pixel_index(n.pixel)].M;
        if (m == 0u) continue;
        s.evaluated++;
        if (luminance(target_contribution(n, L)) > 0.0) z += float(m);
    }
    return z;
}

Reservoir combine(inout PixelState s, Reservoir own) {
    uint stream = round_stream(s, 1u), picks = round_stream(s, 2u);
    uint first = picks;                           // the neighbours' stream, for Z
    Reservoir o = own;
    float wsum = own.p_hat * own.W * float(own.M);
    float m = float(own.M);
    for (uint k = 0u; k < u_neighbours; ++k) {
        PixelState n;
        if (!next_neighbour(s, picks, n)) continue;
        Reservoir r = ris_in[pixel_index(n.pixel)];
        m += float(r.M);
        if (r.light == RIS_NO_LIGHT) continue;
        GpuLight L = lights[r.light];
        vec3 f = target_contribution(s, L);
        if (accept(wsum, luminance(f) * r.W * float(r.M), stream)) keep(o, r.light, f);
    }
    o.M = uint(m);
    if (u_unbiased != 0u && o.p_hat > 0.0) m = unbiased_z(s, own, o.light, first);
    o.W = contribution_weight(wsum, m, o.p_hat);
    return o;
}

void main() {
#if defined(CELLS_ONLY) && CELLS_ONLY
    return;                       // a modelled frame records cells only (ris_resolve.comp)
#endif
    PixelState s = load_pixel();
    if (!s.inside) return;
    uint i = pixel_index(s.pixel);
    Reservoir own = ris_in[i];
    s.evaluated = own.evaluated;
    Reservoir o = s.shading ? combine(s, own) : own;
    o.evaluated = s.evaluated;
    ris_out[i] = o;
}
