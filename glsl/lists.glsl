// Cells of the 2.5D grid (or 2D tiles when u_slices == 1) and their light lists.
//   ranges[cell] = (first entry | first node, count)  ->  entries[] -> lights[]
// define: LIGHTS_DUPLICATED

layout(std430, binding = B_RANGES) readonly buffer Ranges { CellRange ranges[]; };
layout(std430, binding = B_ENTRIES) readonly buffer Entries { uint entries[]; };
#if LIGHTS_DUPLICATED
// Paper figure 5's "duplicated" variant: lists hold copies of the light data.
layout(std430, binding = B_DUP_LIGHTS) readonly buffer DupLights { GpuLight dup_lights[]; };
#define LIST_LIGHT(k) dup_lights[k]
#else
#define LIST_LIGHT(k) lights[entries[k]]
#endif

#include "cells.glsl"

// The entries [first, first + count) that fall in this dispatch's window (pixel.glsl).
void evaluate_list(inout PixelState s, uint first, uint count) {
    uvec2 w = window_part(s, count);
    // priced: light
    for (uint k = first + w.x; k < first + w.y; ++k) evaluate_light(s, LIST_LIGHT(k));
}

// Drobot 2017, "Hierarchical Container iterator scalarized over containers": the wave walks
// the distinct cells its lanes need, one per round (the address of the first lane still
// waiting); the lanes of that cell iterate its list from a wave-uniform address, the others
// wait.  `pending`: this lane still needs `cell`.  One round: its wave-uniform cell `c`;
// false once no lane waits.
bool next_wave_cell(bool pending, uint cell, out uint c) {
#if WAVE_NATIVE
    if (!pending) return false;  // the slides' loop: a lane leaves once its cell is done
    c = waveReadFirstLane(cell);
    return true;
#else
    // The emulated wave is the 8x8 group: every invocation takes part in every round (the
    // reduction holds barriers); the first waiting lane's address is the lowest waiting cell.
    c = groupAllMin(pending ? cell : 0xFFFFFFFFu);
    return c != 0xFFFFFFFFu;
#endif
}

// The scalarized walk over list cells.  Returns the wave's scalar iterations: the rounds
// plus the entries of every cell walked (what a scalar unit loops over).
uint evaluate_cells_scalarized(inout PixelState s, uint cell, bool pending) {
    uint iterations = 0u, c;
    // priced: cell minus: evaluate_list
    while (next_wave_cell(pending, cell, c)) {
        uvec2 r = ranges[c].offset_count;
        iterations += 1u + r.y;
        if (pending && c == cell) {
            evaluate_list(s, r.x, r.y);
            pending = false;
        }
    }
    return iterations;
}
