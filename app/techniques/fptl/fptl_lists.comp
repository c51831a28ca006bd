#version 430
// fptl, step 2 of the chapter: one 64-invocation group per 16x16 tile (pixel.glsl's 8x8
// group); invocation (x, y) owns the tile's 2x2 pixels at (2x, 2y).
//   (a) the tile's min/max depth (and each depth slice's, for 2.5D cells), shared atomics;
//   (b-c) coarse: per step of 64 lights in class order, each invocation tests one light's
//       screen AABB (fptl_aabb.comp) against the tile's rectangle and depth range; the hits
//       keep their order in a shared batch of 64 (the chapter's LDS list);
//   (d) fine pruning: each invocation tests its four pixels against every batch light with
//       evaluate_light's own decision (pixel.glsl: the same float32 test as the shading
//       loop), one bit per batch light and pixel (FPTL_PRUNE 0, coarse only: each batch
//       light whose depth range meets the cell's pixels);
//   (e) the bits OR-reduced per cell (shared atomics), the survivors appended to the cell's
//       list in batch order: the first 24 into its blocks (fptl_common.glsl), the rest into
//       the spill; the list's length and state (spilled, pool full) written in band into
//       its words, the only thing of a cell that shading reads.
// A batch that fills is pruned and emptied and the scan goes on, so a tile's coarse list
// may pass 64 (flag FPTL_COARSE_OVER).  A cell whose list passes 24 is counted first
// (scan 1), reserves exactly its spill in the pool, and the tile scans again (scan 2) to
// write it; the same lights in the same order, so the same positions.  A cell the pool
// cannot hold is flagged FPTL_POOL_FULL and shades every light.  The flags also go to the
// cell's record (fptl_cells: coarse, pruned, flags; FPTL_COVERED: some pixel of the cell
// shades), which the statistics and the next scan window read.  On a driver with a loop
// limit a dispatch scans the class positions [u_scan.x, u_scan.y) and carries each cell's
// state over from the previous one (fptl.scan_windows).
// FPTL_TILE_CAP 1 (a per-tile cap policy, HDRP FPTL: cpu_prep.caps): after (e)'s OR
// reduction, a light past its category's budget in the cell is taken out of the cell's mask
// before positions are given: its rank among that category's lights found so far in the
// cell, in scan order, which the CPU made HDRP's sort-key order (fptl.class_order), so each
// category keeps its lowest sort keys, as lightlistbuild.compute's per-category clamp does.
// FPTL_CELL_SHAPES 1 (--feature-variants: app/techniques/variants.py CELL_PRECOMPUTED): each
// cell's shape word, the OR of 1 << type over the lights its list keeps (scan 1 gives every
// kept light a position, listed and spilled alike; a cap's dropped ones have left the mask),
// a pool-full cell every visible light's (u_frame_shapes, as it shades them all), into
// cell_features[cell]: the bits variant_cells.comp writes for the CSR techniques, which the
// tiles' classification reads.
// define: FPTL_PRUNE FPTL_TILE_CAP FPTL_CELL_SHAPES
#include "generated.glsl"
#include "fptl_structs.glsl"
#include "pixel.glsl"
#include "fptl_common.glsl"

layout(std430, binding = B_FPTL_AABBS) readonly buffer Aabbs { FptlAabb fptl_aabbs[]; };
layout(std430, binding = B_FPTL_LISTS) buffer Lists { uint fptl_lists[]; };
layout(std430, binding = B_FPTL_CELLS) buffer Cells { FptlCell fptl_cells[]; };
layout(std430, binding = B_FPTL_SPILL_HEADS) writeonly buffer Heads { uvec2 fptl_spill_heads[]; };
layout(std430, binding = B_FPTL_SPILL) writeonly buffer Spill { uint fptl_spill[]; };
layout(std430, binding = B_FPTL_COUNTER) coherent buffer Counter { uint fptl_spill_used; };
// FPTL_TILE_CAP: per cell, the lights of each category (budget group) its pruning found,
// kept or dropped (the next scan window's state and the statistics); a bit per light
// (lights[] index) dropped from some cell
layout(std430, binding = B_FPTL_CATEGORY_SEEN) buffer Seen { uvec2 fptl_category_seen[]; };
layout(std430, binding = B_FPTL_DROPPED) buffer Dropped { uint fptl_dropped[]; };
#if FPTL_CELL_SHAPES
layout(std430, binding = B_CELL_FEATURES) buffer CellFeatures { uint cell_features[]; };
uniform uint u_frame_shapes;     // the shape bits of every visible light
#endif

uniform uvec2 u_scan;          // class positions this dispatch scans
uniform uint u_scan_index;
uniform uint u_spill_capacity;
// FPTL_SLICES and 2, as uniforms: loops over cells and scans that the compiler cannot
// unroll (llvmpipe compiles at the first dispatch; unrolled, 16 cells take seconds)
uniform uint u_slices;
uniform uint u_two;
uniform uvec2 u_tile_cap;        // FPTL_TILE_CAP: the budget of category 0 and of category 1
uniform uint u_cap_group_types;  // ... bit t: light type t is in category 1

#define S u_slices

shared uint s_dmin[FPTL_SLICES + 1], s_dmax[FPTL_SLICES + 1];   // per slice, [S]: the tile
shared uint s_ballot[2];
shared uint s_batch_light[2u * FPTL_BATCH];   // the coarse batch: indices into lights[] ...
shared uint s_batch_pos[2u * FPTL_BATCH];     // ... and class positions (fptl_aabbs)
shared uint s_count;
shared uint s_mask[2 * FPTL_SLICES];          // the OR-reduced 64-bit mask of each cell
shared uint s_pruned[FPTL_SLICES];            // each cell's list length so far
shared uint s_start[FPTL_SLICES];             // ... at this dispatch's start
shared uint s_base[FPTL_SLICES];              // this dispatch's spill segment of each cell
shared uint s_flags[FPTL_SLICES];
shared uint s_words[FPTL_SLICES * int(FPTL_LIST_WORDS)];
shared uint s_coarse;
shared uint s_spilling;
#if FPTL_TILE_CAP
shared uint s_seen[2 * FPTL_SLICES];          // per cell and category: found so far
shared uint s_seen_start[2 * FPTL_SLICES];    // ... at this dispatch's start
shared uint s_drop[2 * FPTL_SLICES];          // the batch's lights each cell drops
shared uint s_group1[2];                      // the batch's lights of category 1
#endif
#if FPTL_CELL_SHAPES
shared uint s_shapes[FPTL_SLICES];            // each cell's shape word so far
#endif

PixelState g_px[4];            // this invocation's 2x2 pixels
uint g_slice[4];
vec4 g_tile;                   // the tile's rectangle in pixels: x0, x1, y0, y1

uint lane() { return gl_LocalInvocationIndex; }

bool meets_tile(FptlAabb a, float dmin, float dmax) {
    return a.rect.x <= g_tile.y && a.rect.y >= g_tile.x && a.rect.z <= g_tile.w && a.rect.w >= g_tile.z
        && a.depth.x <= dmax && a.depth.y >= dmin;
}

// evaluate_light's own decision on a copy of the pixel (its shading work is dead code here).
bool affects(PixelState p, GpuLight L) {
    if (!p.shading) return false;
    uint before = p.count;
    evaluate_light(p, L);
    return p.count != before;
}

uvec2 bit_of(uint j) { return j < 32u ? uvec2(1u << j, 0u) : uvec2(0u, 1u << (j - 32u)); }

bool has_bit(uvec2 m, uint j) { return ((j < 32u ? m.x >> j : m.y >> (j - 32u)) & 1u) != 0u; }

uint bits_below(uvec2 m, uint j) {
    return j < 32u ? bitCount(m.x & ((1u << j) - 1u))
                   : bitCount(m.x) + bitCount(m.y & ((1u << (j - 32u)) - 1u));
}

void or_mask(uint c, uvec2 m) {
    if (m.x != 0u) atomicOr(s_mask[2u * c], m.x);
    if (m.y != 0u) atomicOr(s_mask[2u * c + 1u], m.y);
}

#if FPTL_TILE_CAP
// The per-tile cap on the batch's OR-reduced masks: a light whose rank in its category
// (lights found before it in the cell, this batch's lower bits included) reaches the
// category's budget leaves the cell's mask, and is marked dropped (scan 1; scan 2 repeats
// the same decisions from the same state).
void cap_batch(uint m, uint mode) {
    uint me = lane();
    uvec2 g1 = uvec2(s_group1[0], s_group1[1]);
    uint g = me < m && has_bit(g1, me) ? 1u : 0u;
    for (uint c = 0u; c < S; ++c) {
        uvec2 bits = uvec2(s_mask[2u * c], s_mask[2u * c + 1u]);
        if (me < m && has_bit(bits, me)) {
            uvec2 same = g == 1u ? bits & g1 : bits & ~g1;
            if (s_seen[2u * c + g] + bits_below(same, me) >= u_tile_cap[g]) {
                atomicOr(s_drop[2u * c + (me >> 5u)], 1u << (me & 31u));
                uint l = s_batch_light[me];
                if (mode == 0u) atomicOr(fptl_dropped[l >> 5u], 1u << (l & 31u));
            }
        }
    }
    barrier();
    if (me < S) {
        uvec2 bits = uvec2(s_mask[2u * me], s_mask[2u * me + 1u]);
        s_seen[2u * me] += bitCount(bits.x & ~g1.x) + bitCount(bits.y & ~g1.y);
        s_seen[2u * me + 1u] += bitCount(bits.x & g1.x) + bitCount(bits.y & g1.y);
        s_mask[2u * me] = bits.x & ~s_drop[2u * me];
        s_mask[2u * me + 1u] = bits.y & ~s_drop[2u * me + 1u];
    }
    barrier();
}
#endif

// Steps (d)-(e) for the first m lights of the batch.  mode 0: write list positions < 24 and
// count; mode 1: write the spill positions reserved after mode 0.
void flush(uint m, uint mode) {
    uint me = lane();
    if (me < S) { s_mask[2u * me] = 0u; s_mask[2u * me + 1u] = 0u; }
#if FPTL_TILE_CAP
    if (me < S) { s_drop[2u * me] = 0u; s_drop[2u * me + 1u] = 0u; }
    if (me < 2u) s_group1[me] = 0u;
    barrier();
    if (me < m && ((u_cap_group_types >> lights[s_batch_light[me]].id_type.y) & 1u) != 0u)
        atomicOr(s_group1[me >> 5u], 1u << (me & 31u));
#endif
    barrier();
#if FPTL_PRUNE
    uvec2 m0 = uvec2(0u), m1 = uvec2(0u), m2 = uvec2(0u), m3 = uvec2(0u);
    // priced: prune with: light_affects_pixel
    for (uint j = 0u; j < m; ++j) {
        GpuLight L = lights[s_batch_light[j]];
        uvec2 b = bit_of(j);
        if (affects(g_px[0], L)) m0 |= b;
        if (affects(g_px[1], L)) m1 |= b;
        if (affects(g_px[2], L)) m2 |= b;
        if (affects(g_px[3], L)) m3 |= b;
    }
    or_mask(g_slice[0], m0);
    or_mask(g_slice[1], m1);
    or_mask(g_slice[2], m2);
    or_mask(g_slice[3], m3);
#else
    if (me < m) {
        vec2 range = fptl_aabbs[s_batch_pos[me]].depth;
        // priced: prune
        for (uint c = 0u; c < S; ++c)
            if (s_dmin[c] <= s_dmax[c] && range.x <= uintBitsToFloat(s_dmax[c])
                    && range.y >= uintBitsToFloat(s_dmin[c]))
                or_mask(c, bit_of(me));
    }
#endif
    barrier();
#if FPTL_TILE_CAP
    cap_batch(m, mode);
#endif
    uint light = me < m ? s_batch_light[me] : 0u;
#if FPTL_CELL_SHAPES
    uint shape = me < m && mode == 0u ? 1u << lights[light].id_type.y : 0u;
#endif
    for (uint c = 0u; c < S; ++c) {
        uvec2 bits = uvec2(s_mask[2u * c], s_mask[2u * c + 1u]);
        if (me < m && has_bit(bits, me)) {
#if FPTL_CELL_SHAPES
            if (shape != 0u) atomicOr(s_shapes[c], shape);
#endif
            uint p = s_pruned[c] + bits_below(bits, me);
            if (mode == 0u) {
                if (p < FPTL_CAP)
                    atomicOr(s_words[c * FPTL_LIST_WORDS + fptl_word(p)], fptl_put(light, p));
            } else {
                uint from = max(s_start[c], FPTL_CAP);
                if (p >= from && (s_flags[c] & FPTL_POOL_FULL) == 0u)
                    fptl_spill[s_base[c] + p - from] = light;
            }
        }
    }
    barrier();
    if (me < S) s_pruned[me] += bitCount(s_mask[2u * me]) + bitCount(s_mask[2u * me + 1u]);
    barrier();
}

// Steps (b)-(e) over this dispatch's lights (one call site of flush: the last step prunes
// what is left in the batch).
void scan(uint mode, float dmin, float dmax) {
    uint me = lane();
    if (me == 0u) s_count = 0u;
    barrier();
    // priced: cull_test minus: flush
    for (uint first = u_scan.x; ; first += FPTL_BATCH) {
        bool last = first >= u_scan.y;
        uint count = s_count;
        uint found = 0u;
        if (!last) {
            uint i = first + me;
            bool hit = false;
            uint light = 0u;
            if (i < u_scan.y) {
                FptlAabb a = fptl_aabbs[i];
                hit = meets_tile(a, dmin, dmax);
                light = a.light;
            }
            if (me < 2u) s_ballot[me] = 0u;
            barrier();
            if (hit) atomicOr(s_ballot[me >> 5u], 1u << (me & 31u));
            barrier();
            uvec2 hits = uvec2(s_ballot[0], s_ballot[1]);
            if (hit) {
                uint at = count + bits_below(hits, me);   // the lights' order is kept
                s_batch_light[at] = light;
                s_batch_pos[at] = i;
            }
            found = bitCount(hits.x) + bitCount(hits.y);
            count += found;
        }
        barrier();
        // a full batch (or the last lights): prune it, keep the rest
        uint m = count >= FPTL_BATCH ? FPTL_BATCH : (last ? count : 0u);
        if (m > 0u) {
            flush(m, mode);
            uint rest = count - m;
            uint l = 0u, q = 0u;
            if (me < rest) { l = s_batch_light[m + me]; q = s_batch_pos[m + me]; }
            barrier();
            if (me < rest) { s_batch_light[me] = l; s_batch_pos[me] = q; }
            count = rest;
        }
        if (me == 0u) {
            s_count = count;
            if (mode == 0u) s_coarse += found;
        }
        barrier();
        if (last) break;
    }
}

// After scan 1: each cell's spill of this dispatch (its list positions past 24 found in it)
// reserved exactly in the pool, or the cell flagged when the pool cannot hold it.
void reserve(uint me, uint first_cell) {
    if (me < S) {
        uint end = s_pruned[me], from = max(s_start[me], FPTL_CAP);
        uint need = end > from ? end - from : 0u;
        uvec2 head = uvec2(0u);
        if (end > FPTL_CAP) s_flags[me] |= FPTL_SPILLED;
        if (need > 0u && (s_flags[me] & FPTL_POOL_FULL) == 0u) {
            uint base = atomicAdd(fptl_spill_used, need);
            if (base + need > u_spill_capacity || base + need < base) {
                s_flags[me] |= FPTL_POOL_FULL;
            } else {
                head = uvec2(base, need);
                s_spilling = 1u;
            }
        }
        s_base[me] = head.x;
        fptl_spill_heads[u_scan_index * u_cells + first_cell + me] = head;
    }
}

void main() {
    uint me = lane();
    uvec2 tile = gl_WorkGroupID.xy;
    uint first_cell = (tile.y * gl_NumWorkGroups.x + tile.x) * S;
    ivec2 origin = ivec2(tile) * FPTL_TILE;
    ivec2 at = origin + 2 * ivec2(gl_LocalInvocationID.xy);
    g_tile = vec4(origin.x, min(origin.x + FPTL_TILE, u_size.x), origin.y, min(origin.y + FPTL_TILE, u_size.y));
    for (int q = 0; q < 4; ++q) {
        g_px[q] = load_pixel_at(at + ivec2(q & 1, q >> 1));
        g_slice[q] = g_px[q].shading ? fptl_slice(g_px[q].depth) : 0u;
    }
    bool first = u_scan.x == 0u;
    if (me <= S) { s_dmin[me] = 0x7F800000u; s_dmax[me] = 0u; }
    if (me < S) {
        FptlCell c = first ? FptlCell(0u, 0u, 0u, 0u) : fptl_cells[first_cell + me];
        s_pruned[me] = c.pruned;
        s_start[me] = c.pruned;
        s_flags[me] = c.flags;
    }
#if FPTL_TILE_CAP
    if (me < S) {
        uvec2 seen = first ? uvec2(0u) : fptl_category_seen[first_cell + me];
        s_seen[2u * me] = s_seen_start[2u * me] = seen.x;
        s_seen[2u * me + 1u] = s_seen_start[2u * me + 1u] = seen.y;
    }
#endif
#if FPTL_CELL_SHAPES
    if (me < S) s_shapes[me] = first ? 0u : cell_features[first_cell + me];
#endif
    if (me == 0u) {
        s_coarse = first ? 0u : fptl_cells[first_cell].coarse;
        s_spilling = 0u;
    }
    for (uint w = me; w < S * FPTL_LIST_WORDS; w += 64u)
        s_words[w] = first ? 0u : fptl_lists[first_cell * FPTL_LIST_WORDS + w];
    barrier();
    // (a) depths are positive floats, whose bit patterns order like the values
    // priced: depth
    for (int q = 0; q < 4; ++q)
        if (g_px[q].shading) {
            uint d = floatBitsToUint(g_px[q].depth);
            atomicMin(s_dmin[S], d); atomicMax(s_dmax[S], d);
            atomicMin(s_dmin[g_slice[q]], d); atomicMax(s_dmax[g_slice[q]], d);
        }
    barrier();
    bool empty = s_dmin[S] > s_dmax[S];
    float dmin = uintBitsToFloat(s_dmin[S]), dmax = uintBitsToFloat(s_dmax[S]);

    // scan 1 counts and fills the blocks; scan 2 (only where a list passed 24) the spill
    for (uint mode = 0u; mode < u_two; ++mode) {
        if (mode == 1u) {
            barrier();
            reserve(me, first_cell);
            barrier();
            if (s_spilling == 0u) break;
            if (me < S) s_pruned[me] = s_start[me];
#if FPTL_TILE_CAP
            if (me < S) {
                s_seen[2u * me] = s_seen_start[2u * me];
                s_seen[2u * me + 1u] = s_seen_start[2u * me + 1u];
            }
#endif
            barrier();
        }
        if (!empty) scan(mode, dmin, dmax);
    }
    barrier();
    // the lists with their state in band (fptl_common.glsl): all shading reads of a cell
    for (uint w = me; w < S * FPTL_LIST_WORDS; w += 64u) {
        uint c = w / FPTL_LIST_WORDS, b = w % FPTL_LIST_WORDS;
        uint listed = min(s_pruned[c], FPTL_CAP);
        uint v = s_words[w];
#if FPTL_INDEX_BITS == 10
        v = (v & ((1u << FPTL_BLOCK_COUNT_SHIFT) - 1u)) |              // the A2 count
            (fptl_block_count(b, listed, s_flags[c]) << FPTL_BLOCK_COUNT_SHIFT);
#else
        if (b == 0u) v = fptl_count_word(listed, s_flags[c]);
#endif
        fptl_lists[first_cell * FPTL_LIST_WORDS + w] = v;
    }
    // the records, for the statistics (and the next scan window's state); shading never
    // reads them
#if FPTL_TILE_CAP
    if (me < S) fptl_category_seen[first_cell + me] = uvec2(s_seen[2u * me], s_seen[2u * me + 1u]);
#endif
#if FPTL_CELL_SHAPES
    if (me < S)
        cell_features[first_cell + me] = (s_flags[me] & FPTL_POOL_FULL) != 0u ? u_frame_shapes : s_shapes[me];
#endif
    if (me < S)
        fptl_cells[first_cell + me] = FptlCell(s_coarse, s_pruned[me],
                                               s_flags[me] | (s_coarse > FPTL_BATCH ? FPTL_COARSE_OVER : 0u)
                                               | (s_dmin[me] <= s_dmax[me] ? FPTL_COVERED : 0u), 0u);
}
