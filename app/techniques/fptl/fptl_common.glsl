// fptl (app/techniques/fptl.py): what list building and shading share.
//
//   cell = (ty * tiles_x + tx) * FPTL_SLICES + slice     (tile-major, as cpu_prep.grid; one
//                                                         slice: one list per 16x16 tile)
//   fptl_lists[cell * FPTL_LIST_WORDS ..]  the cell's first FPTL_CAP lights, in class order,
//     and the list's state, in band: shading reads these words and nothing else of the cell
//     (fptl_cells[cell] = (coarse, pruned, flags) is written for the statistics only).
//
//     10-bit (<= 1,024 visible lights), the chapter's format: 8 R10G10B10A2 blocks, three
//       indices in bits 0-9, 10-19, 20-29 and the count of active ones (0-3) in bits 30-31,
//       32 B a cell.  The length is the sum of the eight counts.  Blocks fill front to back,
//       so in a plain list an empty block 0 means an empty list (all eight counts 0); the two
//       states a list can be in besides plain use the count patterns no plain list has, an
//       empty block 0 before non-empty blocks (no slot is given up, no index reserved: all
//       1,024 indices stay lights):
//         counts 0,3,3,3,3,3,3,3  spilled: all 24 slots hold the list's first 24 lights, the
//                                 rest are in fptl_spill at the scan windows' heads;
//         counts 0,1,0,0,0,0,0,0  pool full: the spill pool could not hold the list; the
//                                 cell shades every visible light.
//     16-bit (<= 65,536) and 32-bit: one count word first, then the indices (two a word, 12
//       words; one a word, 24), 13 and 25 words a cell.  Count word: the listed entries
//       (0-24) in bits 0-7, the state (FPTL_SPILLED, FPTL_POOL_FULL, the cell flags' values)
//       in bits 8-15.  A count word rather than a sentinel: a 16-bit index takes all 65,536
//       values at the format's limit (a sentinel would lower it), the loops need the count
//       before they start (dispatch windows, window_part), which a sentinel gives only after
//       a scan of the words, and the two states would need a second reserved value or slot;
//       4 B a cell more, in formats that are not the chapter's anyway.
//   A spilled cell's rest, pruned - FPTL_CAP lights, is at each scan window's head
//     fptl_spill_heads[scan * cells + cell] = (first, count), in order; shading reads the
//     heads of spilled cells only.
// define: FPTL_SLICES FPTL_INDEX_BITS

// FPTL_TILE (16), FPTL_CAP (24), FPTL_BATCH (64) and the cell flags FPTL_COARSE_OVER,
// FPTL_SPILLED, FPTL_POOL_FULL come with the structs from app/techniques/fptl.py
// (fptl_structs.glsl, included first); the format's words (FPTL_LIST_WORDS, FPTL_HEAD_WORDS:
// 0 at 10 bits, the counts are in the blocks' A2 fields, else the count word;
// FPTL_PER_WORD, FPTL_INDEX_MASK), its count fields and the states' count patterns from
// the same module (fptl_format.glsl).
#include "fptl_format.glsl"
#define FPTL_STATE (FPTL_SPILLED | FPTL_POOL_FULL)

uniform int u_fptl_tiles_x;
uniform float u_slice_scale;   // listing 4, scale corrected (cpu_prep.grid)
uniform float u_slice_bias;
uniform uint u_cells;          // tiles x slices
uniform uint u_scans;          // list-building scan windows (spill heads per cell)

// Tree paper listing 4 (as lists.glsl's slice_of); both fptl passes call this one function
// on the same depth, so a pixel's cell is the same in both.
uint fptl_slice(float depth) {
#if FPTL_SLICES > 1
    float slice = max(log(depth) * u_slice_scale + u_slice_bias, 0.0);
    return uint(min(int(slice), FPTL_SLICES - 1));
#else
    return 0u;
#endif
}

// priced: cell
uint fptl_cell(ivec2 pixel, float depth) {
    ivec2 t = pixel / FPTL_TILE;
    return (uint(t.y) * uint(u_fptl_tiles_x) + uint(t.x)) * uint(FPTL_SLICES) + fptl_slice(depth);
}

// Position k of a list: its word (after the count word of the wide formats), and the
// index's shift in that word (10, 16 or 32 bits apart: 32 / 3 = 10 leaves bits 30-31 of a
// 10-bit block to its count).
uint fptl_word(uint k) { return FPTL_HEAD_WORDS + k / FPTL_PER_WORD; }
uint fptl_shift(uint k) { return (k % FPTL_PER_WORD) * (32u / FPTL_PER_WORD); }
uint fptl_get(uint word, uint k) { return (word >> fptl_shift(k)) & FPTL_INDEX_MASK; }
uint fptl_put(uint index, uint k) { return index << fptl_shift(k); }

// The list's state in band (the format above): what the list pass writes ...
//   10-bit: the A2 count of block b of a cell with `listed` entries in its blocks and the
//   state bits `flags` (FPTL_SPILLED, FPTL_POOL_FULL: a pool-full cell has spilled too)
uint fptl_block_count(uint b, uint listed, uint flags) {
    if ((flags & FPTL_POOL_FULL) != 0u) return FPTL_POOL_FULL_COUNTS[b];
    if ((flags & FPTL_SPILLED) != 0u) return FPTL_SPILLED_COUNTS[b];
    return listed > 3u * b ? min(listed - 3u * b, 3u) : 0u;
}
//   16/32-bit: the count word
uint fptl_count_word(uint listed, uint flags) {
    return ((flags & FPTL_POOL_FULL) != 0u ? 0u : listed) |
           ((flags & FPTL_STATE) << FPTL_COUNT_WORD_STATE_SHIFT);
}

// ... and what shading decodes: (entries in the blocks, state bits).
//   10-bit: from block 0's count and the sum of the eight counts
uvec2 fptl_decode_counts(uint c0, uint sum) {
    if (c0 != 0u || sum == 0u) return uvec2(sum, 0u);                   // a plain list
    return sum == FPTL_SPILLED_SUM ? uvec2(FPTL_CAP, FPTL_SPILLED) : uvec2(0u, FPTL_STATE);
}
//   16/32-bit: from the count word
uvec2 fptl_decode_count_word(uint w) {
    return uvec2(w & FPTL_COUNT_WORD_LISTED, (w >> FPTL_COUNT_WORD_STATE_SHIFT) & FPTL_STATE);
}
