#version 430
// fptl, deferred lighting: every pixel of a tile (or 2.5D cell) pulls the same fine-pruned
// list (fptl_lists.comp), in class order (spheres and capsules, cones, boxes: each class one
// contiguous run, so evaluate_light's type branch is uniform over a run), then the cell's
// spill of lists longer than 24.  A cell the spill pool could not hold shades every light.
#include "generated.glsl"
#include "fptl_structs.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "fptl_common.glsl"

layout(std430, binding = B_FPTL_LISTS) readonly buffer Lists { uint fptl_lists[]; };
layout(std430, binding = B_FPTL_CELLS) readonly buffer Cells { FptlCell fptl_cells[]; };
layout(std430, binding = B_FPTL_SPILL_HEADS) readonly buffer Heads { uvec2 fptl_spill_heads[]; };
layout(std430, binding = B_FPTL_SPILL) readonly buffer Spill { uint fptl_spill[]; };

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        uint cell = fptl_cell(s.pixel, s.depth);
        FptlCell c = fptl_cells[cell];
        if ((c.flags & FPTL_POOL_FULL) != 0u) {
            evaluate_all_lights(s);
        } else {
            uint first = cell * FPTL_LIST_WORDS;
            uvec2 w = window_part(s, min(c.pruned, FPTL_CAP));
            for (uint k = w.x; k < w.y; ++k)
                evaluate_light(s, lights[fptl_get(fptl_lists[first + fptl_word(k)], k)]);
            if (c.pruned > FPTL_CAP)
                for (uint scan = 0u; scan < u_scans; ++scan) {
                    uvec2 head = fptl_spill_heads[scan * u_cells + cell];
                    uvec2 part = window_part(s, head.y);
                    for (uint k = part.x; k < part.y; ++k) evaluate_light(s, lights[fptl_spill[head.x + k]]);
                }
        }
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
