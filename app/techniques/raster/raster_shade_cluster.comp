#version 430
// raster, cluster rasterizer: each pixel loops over its cluster's bit array (the clusters
// the proxies marked, raster_cluster.frag), per lane, like clustered's loop over its cell's
// list.  Dispatch windows (pixel.glsl): a pixel's sequence position of light N is N itself,
// so window [lo, hi) takes the words of lights lo..hi-1 and masks the bits outside it.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "slices.glsl"
#include "zbin_mask.glsl"

layout(std430, binding = B_CLUSTER_BITS) readonly buffer ClusterBits { uint cluster_bits[]; };
uniform int u_tile;
uniform ivec2 u_tiles;       // tiles in x and y
uniform uint u_words;

void main() {
    PixelState s = load_pixel();
    if (s.shading && u_window.x < u_window.y) {
        ivec2 t = s.pixel / u_tile;
        uint cell = uint(t.y * u_tiles.x + t.x) * uint(u_slices) + slice_of(s.depth);
        s.cell = cell;
        CELLS_ONLY_RETURN(s);
        uint address = cell * u_words;
        uint last = min(u_window.y - 1u, 0x7FFFFFFFu);
        uint wordEnd = min(u_words, last / 32u + 1u);
        // priced: word
        for (uint w = u_window.x / 32u; w < wordEnd; ++w) {
            uint mask = cluster_bits[address + w] & window_mask(w);
            // priced: light
            while (mask != 0u) {
                uint bit = uint(findLSB(mask));
                mask ^= 1u << bit;
                evaluate_light(s, lights[32u * w + bit]);
            }
        }
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
