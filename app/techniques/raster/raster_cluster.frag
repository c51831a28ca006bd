#version 450
// raster, the slides' cluster rasterizer (Drobot 2017): proxies mark the clusters (tile x
// depth slice, cpu_prep.grid's listing-4 slices) of their light's volume; no depth test.
//   u_mode RASTER_MODE_MARK: back faces of proxies the eye is outside of mark the clusters they
//             conservatively touch in this pixel's column
//          RASTER_MODE_WALK (after every MARK): their front faces walk from their
//             conservative depth to the farthest cluster of the column this light MARKed
//          RASTER_MODE_INSIDE: back faces of proxies holding the eye (or reaching the near
//             plane) walk from the near plane (slice 0) to their conservative depth
// Conservative depth of the triangle over the pixel, as the slides give it: w -+ (|dw/dx| +
// |dw/dy|), clamped to the triangle's vertex depths (GetVertexParameterP0..2: here the
// vertex shader computes all three corners, RASTER_TRI_BOUNDS), and never excluding w at
// the pixel centre itself (a pixel centre the rasterizer covers a fraction of a pixel
// outside the triangle extrapolates it).  The walk goes to the column's farthest MARK, not
// to the first marked cluster: with several pixels in a column the first marked cluster
// may be another pixel's nearer back face; the slides' version relies on neighbouring
// pixels' MARK ranges (each widened by its footprint's depth spread) overlapping into one
// run (they did in every test here), this one needs no such argument: the proxy's part in
// the column is convex, so every slice from its nearest front to its farthest back is
// touched (exact at cluster granularity, and the same marks in practice).
//   RASTER_MSAA: each covered sample stands for the full-resolution pixel of its quadrant,
//   at the (dilated) proxy's exact depth at that sample (docs/raster.md).
//   RASTER_DEPTH_BOUND: the slides' "conservative depth from prepass to early reject": a
//   pixel only ever reads the cluster of its own depth's slice, so of a tile's clusters only
//   slices [near, far] of its min / max scene depth (raster_tile_depth.comp) are read, and
//   a tile with no geometry has none.  MARK and WALK write only those, with one exception
//   that keeps the WALK's search exact: a MARK range wholly outside [near, far] writes one
//   cluster no pixel reads, just outside on its own side (its far end when in front, far + 1
//   when behind), so a WALK still tells "the tile's back faces are all in front of the read
//   slices" (walk nothing there) and "behind them" (walk to far) from "no MARK at all"
//   (walk to far, the unbounded rule); docs/raster.md has the argument.
// define: RASTER_MSAA RASTER_COMPACT WAVE_NATIVE RASTER_DEPTH_BOUND
#define WAVE_FRAGMENT 1          // wave.glsl (through raster_common.glsl): no group emulation
#if RASTER_COMPACT && WAVE_NATIVE      // the loader writes the native path's #extension lines
#define COMPACT 1
#else
#define COMPACT 0
#endif
#include "raster_common.glsl"
#include "slices.glsl"

flat in vec2 v_tri_depth;     // min, max view depth of the triangle's three corners
#if RASTER_DEPTH_BOUND
// per tile (x ~bits of the min scene depth, y bits of the max; y 0: no geometry)
layout(std430, binding = B_RASTER_TILE_DEPTH) readonly buffer TileDepth { uvec2 tile_depth[]; };
#endif

uint cell_word(ivec2 pixel, uint slice) {
    ivec2 t = pixel / u_tile;
    return (uint(t.y * u_tiles.x + t.x) * uint(u_slices) + slice) * u_words + v_light / 32u;
}

bool marked(ivec2 pixel, uint slice) {
    return (BITS[cell_word(pixel, slice)] & (1u << (v_light & 31u))) != 0u;
}

// The clusters of the pixel's column this fragment marks, for depths [lo, hi] of the proxy.
void column(ivec2 pixel, float lo, float hi) {
    if (any(greaterThanEqual(pixel, u_size))) return;
    uint s0 = slice_of(lo * (1.0 - SHADER_SLACK));
    uint s1 = slice_of(hi * (1.0 + SHADER_SLACK));
    uint top = uint(u_slices - 1);
    uint near = 0u, far = top;                         // the slices this tile's pixels read
#if RASTER_DEPTH_BOUND
    ivec2 t = pixel / u_tile;
    uvec2 bound = tile_depth[t.y * u_tiles.x + t.x];
    if (bound.y == 0u) return;                         // no geometry: no pixel reads the tile
    near = slice_of(uintBitsToFloat(~bound.x) * (1.0 - SHADER_SLACK));
    far = slice_of(uintBitsToFloat(bound.y) * (1.0 + SHADER_SLACK));
#endif
    if (u_mode == RASTER_MODE_MARK) {                   // MARK: [s0, s1] within [near, far]
        if (s1 < near) s0 = s1;                        //   wholly in front: its far end alone
        else if (s0 > far) s0 = s1 = far + 1u;         //   wholly behind: far + 1 alone
        else { s0 = max(s0, near); s1 = min(s1, far); }
    } else {
        if (u_mode == RASTER_MODE_INSIDE) s0 = 0u;      // eye inside: from the near plane
        if (u_mode == RASTER_MODE_WALK) {               // WALK: to the column's farthest MARK
            if (s0 > far) return;                      //   wholly behind what the tile reads
            uint end = min(top, far + 1u);
            s1 = end;
            while (s1 > s0 && !marked(pixel, s1)) --s1;
            if (s1 == s0 && !marked(pixel, s0)) s1 = far;   // no MARK at or past s0: to the end
        }
        s0 = max(s0, near);
        s1 = min(s1, far);
        if (s0 > s1) return;
    }
#if RASTER_STATS
    count_lanes(2u);
#endif
    // a column's pixels mark the same clusters over and over: read before the atomic (the
    // bits only ever get set, so a stale read costs one redundant atomic at most)
    uint bit = 1u << (v_light & 31u);
    for (uint s = s0; s <= s1; ++s) {
        uint w = cell_word(pixel, s);
        if ((BITS[w] & bit) == 0u) mark(w);
    }
}

// priced: fragment
void main() {
    float inv_d = gl_FragCoord.w;                      // 1 / view depth: affine on screen
    vec2 grad = vec2(dFdx(inv_d), dFdy(inv_d));
    float w = 1.0 / inv_d;
    float spread = abs(dFdx(w)) + abs(dFdy(w));
    // helper invocations (there for the derivatives) leave now: they must not take part in
    // WaveCompactValue's ballots, where one could be the first lane of a key and swallow
    // the real lanes' atomic (a helper's atomics have no effect)
    if (gl_HelperInvocation) return;
#if RASTER_STATS
    count_lanes(0u);
#endif
#if RASTER_MSAA
    ivec2 base = ivec2(gl_FragCoord.xy) * 2;
    for (int k = 0; k < 4; ++k) {
        if ((gl_SampleMaskIn[0] & (1 << k)) == 0) continue;
        float d = 1.0 / (inv_d + dot(grad, u_sample_pos[k] - 0.5));
        column(base + u_sample_pixel[k], d, d);
    }
#else
    float lo = min(w, max(w - spread, v_tri_depth.x));
    float hi = max(w, min(w + spread, v_tri_depth.y));
    column(ivec2(gl_FragCoord.xy), lo, hi);
#endif
}
