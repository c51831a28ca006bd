#version 430
// fptl, deferred lighting: every pixel of a tile (or 2.5D cell) pulls the same fine-pruned
// list (fptl_lists.comp) as the chapter stores it, and nothing else of the cell: the list's
// length and state are in band in its words (fptl_common.glsl).  10-bit indices: the eight
// R10G10B10A2 blocks, the length the sum of their 2-bit counts (the chapter's 32 B a tile,
// read whole); 16/32-bit: the count word, then the index words the list fills.  A spilled
// list (flagged in its counts / count word) then reads its scan windows' spill heads and
// spill; a cell the spill pool could not hold shades every light.
//
// The chapter's fixed sequence of per-type loops (its step 1(b)): the lights are sorted by
// shape on the CPU (point, capsule | spot | box: the chapter's sphere/capsule, cone and box
// classes, app/techniques/fptl.py), so every run of a list is points, then capsules, spots,
// boxes.  Each loop evaluates one shape with its type a constant (evaluate_light_as: only
// that shape's code) and stops at the first entry of another shape; a shape the scene lacks
// compiles no loop (HAS_*, features.glsl), one the tile lacks runs none.  Every pixel of a
// cell walks the same list, so the loops' exits are uniform over the cell's pixels.
// FPTL_TYPE_LOOPS 0 (the `type_loops` option off): one loop, the light code branching on type.
#include "generated.glsl"
#include "fptl_structs.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "fptl_common.glsl"
// define: FPTL_TYPE_LOOPS

layout(std430, binding = B_FPTL_LISTS) readonly buffer Lists { uint fptl_lists[]; };
layout(std430, binding = B_FPTL_SPILL_HEADS) readonly buffer Heads { uvec2 fptl_spill_heads[]; };
layout(std430, binding = B_FPTL_SPILL) readonly buffer Spill { uint fptl_spill[]; };

// Entry k of a run: the cell's packed blocks, or a spill window's flat indices.
uint run_entry(uint first, uint k, bool spill) {
    return spill ? fptl_spill[first + k] : fptl_get(fptl_lists[first + fptl_word(k)], k);
}

// Entries [k, end) of one shape; returns where the run leaves that shape.
uint type_loop(inout PixelState s, uint first, uint k, uint end, bool spill, uint type) {
    // priced: light
    for (; k < end; ++k) {
        uint i = run_entry(first, k, spill);
        if (lights[i].id_type.y != type) break;
        evaluate_light_as(s, lights[i], type);
    }
    return k;
}

// One class-ordered run of `count` entries, the part of it in this dispatch's window.
void shade_run(inout PixelState s, uint first, uint count, bool spill) {
    uvec2 w = window_part(s, count);
    uint k = w.x;
#if FPTL_TYPE_LOOPS    // the run is in shape order (class_order): the loops end at w.y
#if HAS_POINT
    k = type_loop(s, first, k, w.y, spill, LIGHT_POINT);
#endif
#if HAS_CAPSULE
    k = type_loop(s, first, k, w.y, spill, LIGHT_CAPSULE);
#endif
#if HAS_SPOT
    k = type_loop(s, first, k, w.y, spill, LIGHT_SPOT);
#endif
#if HAS_BOX
    k = type_loop(s, first, k, w.y, spill, LIGHT_BOX);
#endif
#else
    // priced: light
    for (; k < w.y; ++k) evaluate_light(s, lights[run_entry(first, k, spill)]);
#endif
}

// The cell's list state from its words: (entries in the blocks, FPTL_SPILLED / FPTL_POOL_FULL).
// priced: cell
uvec2 list_state(uint first) {
#if FPTL_INDEX_BITS == 10
    uint sum = 0u;                         // all eight blocks: 32 B, one aligned fetch
    for (uint b = 0u; b < FPTL_LIST_WORDS; ++b)
        sum += fptl_lists[first + b] >> FPTL_BLOCK_COUNT_SHIFT;
    return fptl_decode_counts(fptl_lists[first] >> FPTL_BLOCK_COUNT_SHIFT, sum);
#else
    return fptl_decode_count_word(fptl_lists[first]);
#endif
}

void main() {
    PixelState s = load_pixel();
    if (s.shading) {
        uint cell = fptl_cell(s.pixel, s.depth);
        s.cell = cell;
        CELLS_ONLY_RETURN(s);
        uint first = cell * FPTL_LIST_WORDS;
        uvec2 state = list_state(first);
        if ((state.y & FPTL_POOL_FULL) != 0u) {
            evaluate_all_lights(s);
        } else {
            shade_run(s, first, state.x, false);
            if ((state.y & FPTL_SPILLED) != 0u)      // only flagged cells read spill heads
                for (uint scan = 0u; scan < u_scans; ++scan) {
                    uvec2 head = fptl_spill_heads[scan * u_cells + cell];
                    shade_run(s, head.x, head.y, true);
                }
        }
    }
    store_pixel(s);
    write_wave_stats(s.evaluated, CASE_LIST);
}
