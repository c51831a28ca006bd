#version 430
// raster, cluster rasterizer: each pixel loops over its cluster's bit array (the clusters
// the proxies marked, raster_cluster.frag), per lane, like clustered's loop over its cell's
// list.  Dispatch windows (pixel.glsl): a pixel's sequence position of light N is N itself,
// so window [lo, hi) takes the words of lights lo..hi-1 and masks the bits outside it.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "slices.glsl"

layout(std430, binding = B_CLUSTER_BITS) readonly buffer ClusterBits { uint cluster_bits[]; };
uniform int u_tile;
uniform int u_tiles_x;
uniform uint u_words;

// Bits of word w whose light lies in [lo, hi] (none when lo > hi).
uint range_mask(uint lo, uint hi, uint w) {
    int base = int(w * 32u);
    uint a = uint(clamp(int(lo) - base, 0, 32));
    uint b = uint(clamp(int(hi) - base, -1, 31) + 1);
    uint width = b > a ? b - a : 0u;
    return width == 32u ? 0xFFFFFFFFu : ((1u << width) - 1u) << (a & 31u);
}

void main() {
    PixelState s = load_pixel();
    if (s.shading && u_window.x < u_window.y) {
        ivec2 t = s.pixel / u_tile;
        uint cell = uint(t.y * u_tiles_x + t.x) * uint(u_slices) + slice_of(s.depth);
        s.cell = cell;
        CELLS_ONLY_RETURN(s);
        uint address = cell * u_words;
        uint last = min(u_window.y - 1u, 0x7FFFFFFFu);
        uint wordEnd = min(u_words, last / 32u + 1u);
        for (uint w = u_window.x / 32u; w < wordEnd; ++w) {
            uint mask = cluster_bits[address + w] & range_mask(min(u_window.x, 0x7FFFFFFFu), last, w);
            while (mask != 0u) {
                uint bit = uint(findLSB(mask));
                mask ^= 1u << bit;
                evaluate_light(s, lights[32u * w + bit]);
            }
        }
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
