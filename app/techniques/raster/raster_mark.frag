#version 450
// raster (Drobot 2017): a proxy fragment that survived the early depth (and stencil) test
// marks its light's bit in its tile's flat bit array (zbin's layout), after the depth bounds
// test emulated here against the G-buffer's linear depth.  Exactness: docs/raster.md.
//   RASTER_MSAA     one fragment per half-resolution pixel: each covered sample stands for
//                   the full-resolution pixel of its quadrant (u_sample_pixel)
//   RASTER_COMPACT  WaveCompactValue (the slides' listing) on the native subgroup: the first
//                   lane per distinct bit issues the atomic (needs WAVE_NATIVE; else plain)
//   RASTER_STATS    the untimed twin: counts fragments, atomics and each light's tiles
//   u_mode          RASTER_MODE_FRONT / _BACK faces, or _STENCIL: the stencil sequence
//                   (u_step 0 front faces, 1 back faces)
// define: RASTER_MSAA RASTER_COMPACT WAVE_NATIVE
#define WAVE_FRAGMENT 1          // wave.glsl (through raster_common.glsl): no group emulation
#if RASTER_COMPACT && WAVE_NATIVE      // the loader writes the native path's #extension lines
#define COMPACT 1
#else
#define COMPACT 0
#endif
#if RASTER_MSAA
#extension GL_ARB_post_depth_coverage : enable
#endif
#include "raster_common.glsl"

layout(early_fragment_tests) in;
#if RASTER_MSAA && defined(GL_ARB_post_depth_coverage)
layout(post_depth_coverage) in;     // gl_SampleMaskIn: the samples that passed the tests
#endif

layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;   // xyz view space, w linear depth (0 = sky)

// Whether the scene point at `pixel` can lie in the light's volume along the proxy surface
// at view depth `proxy_depth`: scene depth in the light's span (depth bounds test) and on
// the inner side of the surface (front faces: behind it; back faces: before it).
bool passes(ivec2 pixel, float proxy_depth, RasterProxy pr, bool back) {
    if (any(greaterThanEqual(pixel, u_size))) return false;
    float ds = texelFetch(g_position, pixel, 0).w;
    if (ds <= 0.0) return false;                                    // sky: nothing to shade
    if (ds < pr.depth_span.x * (1.0 - SHADER_SLACK) || ds > pr.depth_span.y * (1.0 + SHADER_SLACK))
        return false;
    return back ? proxy_depth >= ds * (1.0 - SHADER_SLACK) : proxy_depth <= ds * (1.0 + SHADER_SLACK);
}

uint word_of(ivec2 pixel) {
    ivec2 t = pixel / u_tile;
    return uint(t.y * u_tiles.x + t.x) * u_words + v_light / 32u;
}

#if RASTER_MSAA
#define NO_WORD 0xFFFFFFFFu
// The word sample k marks (its quadrant's full-res pixel), NO_WORD if it is not covered (or,
// with post-depth coverage, failed the early test) or fails the exact test.
uint sample_word(int k, float inv_d, vec2 grad, RasterProxy pr, bool back) {
    if ((gl_SampleMaskIn[0] & (1 << k)) == 0) return NO_WORD;
    ivec2 pixel = ivec2(gl_FragCoord.xy) * 2 + u_sample_pixel[k];
    float depth = 1.0 / (inv_d + dot(grad, u_sample_pos[k] - 0.5));
    if (!passes(pixel, depth, pr, back)) return NO_WORD;
#if RASTER_STATS
    count_lanes(2u);
#endif
    return word_of(pixel);
}
#endif

// priced: fragment
void main() {
    // The proxy's view depth d: 1 / d = gl_FragCoord.w is affine in screen space, so its
    // derivatives give it at any sample exactly (llvmpipe's interpolateAtSample returns the
    // pixel centre's value; the slides estimate depth from ddx / ddy of w the same way).
    float inv_d = gl_FragCoord.w;
    vec2 grad = vec2(dFdx(inv_d), dFdy(inv_d));
    if (u_mode == RASTER_MODE_STENCIL && u_step == 0) return;   // front faces only set the stencil
    // helper invocations (there for the derivatives) leave now: they must not take part in
    // WaveCompactValue's ballots, where one could be the first lane of a key and swallow
    // the real lanes' atomic (a helper's atomics have no effect)
    if (gl_HelperInvocation) return;
    bool back = u_mode != RASTER_MODE_FRONT;
    RasterProxy pr = proxies[v_light];
#if RASTER_STATS
    count_lanes(0u);
#endif
#if RASTER_MSAA
    // the four samples unrolled, their words de-duplicated in registers (a local array costs
    // llvmpipe scratch memory: 1.6x the pass)
    uint w0 = sample_word(0, inv_d, grad, pr, back);
    uint w1 = sample_word(1, inv_d, grad, pr, back);
    uint w2 = sample_word(2, inv_d, grad, pr, back);
    uint w3 = sample_word(3, inv_d, grad, pr, back);
    if (w0 != NO_WORD) mark(w0);
    if (w1 != NO_WORD && w1 != w0) mark(w1);
    if (w2 != NO_WORD && w2 != w0 && w2 != w1) mark(w2);
    if (w3 != NO_WORD && w3 != w0 && w3 != w1 && w3 != w2) mark(w3);
#else
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    if (!passes(pixel, 1.0 / inv_d, pr, back)) return;
#if RASTER_STATS
    count_lanes(2u);
#endif
    mark(word_of(pixel));
#endif
}
