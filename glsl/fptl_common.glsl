// fptl (app/techniques/fptl.py): what list building and shading share.
//
//   cell = (ty * tiles_x + tx) * FPTL_SLICES + slice     (tile-major, as cpu_prep.grid; one
//                                                         slice: one list per 16x16 tile)
//   fptl_lists[cell * FPTL_LIST_WORDS ..]  the cell's first FPTL_CAP lights, in class order:
//     10-bit (<= 1,024 visible lights): 8 R10G10B10A2 blocks, three indices in bits 0-9,
//       10-19, 20-29 and the count of active ones (0-3) in bits 30-31 (32 B a cell);
//     16-bit (<= 65,536): two indices a word, 12 words; 32-bit: one a word, 24 words.
//   fptl_cells[cell] = (coarse, pruned, flags): the list is min(pruned, FPTL_CAP) long; the
//     rest, pruned - FPTL_CAP lights, are in fptl_spill at each scan window's head
//     fptl_spill_heads[scan * cells + cell] = (first, count), in order.
// define: FPTL_SLICES FPTL_INDEX_BITS

// FPTL_TILE (16), FPTL_CAP (24), FPTL_BATCH (64) and the cell flags FPTL_COARSE_OVER,
// FPTL_SPILLED, FPTL_POOL_FULL come with the structs from app/techniques/fptl.py
// (fptl_structs.glsl, included first).

#if FPTL_INDEX_BITS == 10
#define FPTL_LIST_WORDS 8u
#define FPTL_PER_WORD 3u
#define FPTL_INDEX_MASK 0x3FFu
#elif FPTL_INDEX_BITS == 16
#define FPTL_LIST_WORDS 12u
#define FPTL_PER_WORD 2u
#define FPTL_INDEX_MASK 0xFFFFu
#else
#define FPTL_LIST_WORDS 24u
#define FPTL_PER_WORD 1u
#define FPTL_INDEX_MASK 0xFFFFFFFFu
#endif

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

uint fptl_cell(ivec2 pixel, float depth) {
    ivec2 t = pixel / FPTL_TILE;
    return (uint(t.y) * uint(u_fptl_tiles_x) + uint(t.x)) * uint(FPTL_SLICES) + fptl_slice(depth);
}

// Position k of a list: its word, and the index's shift in that word (10, 16 or 32 bits
// apart: 32 / 3 = 10 leaves bits 30-31 of a 10-bit block to its count).
uint fptl_word(uint k) { return k / FPTL_PER_WORD; }
uint fptl_shift(uint k) { return (k % FPTL_PER_WORD) * (32u / FPTL_PER_WORD); }
uint fptl_get(uint word, uint k) { return (word >> fptl_shift(k)) & FPTL_INDEX_MASK; }
uint fptl_put(uint index, uint k) { return index << fptl_shift(k); }
