#version 430
// tiled: the pixel's tile list from the tile_cull pass; an overflowed tile (count
// 0xFFFFFFFF) shades every visible light.
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        s.cell = cell_of(s);
        CELLS_ONLY_RETURN(s);
        uvec2 r = ranges[s.cell].offset_count;
        if (r.y == 0xFFFFFFFFu)
            evaluate_all_lights(s);
        else
            evaluate_list(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
