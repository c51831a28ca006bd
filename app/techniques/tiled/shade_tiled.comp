#version 430
// tiled: the pixel's tile list from the tile_cull pass; an overflowed tile (count
// TILE_OVERFLOW) shades every visible light.
#include "generated.glsl"
#include "tiled_lists.glsl"         // TILE_OVERFLOW, from app/techniques/tiled.py
#include "wave.glsl"
#include "common.glsl"
#include "lists.glsl"

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        s.cell = cell_of(s);
        CELLS_ONLY_RETURN(s);
        uvec2 r = ranges[s.cell].offset_count;
        if (r.y == TILE_OVERFLOW)
            evaluate_all_lights(s);
        else
            evaluate_list(s, r.x, r.y);
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
