// Shared by every shading pass: the pixel (pixel.glsl) and the frame's outputs, written by
// the shading pass of every technique (app.pipeline.passes.frame_outputs).
#include "pixel.glsl"

// read back by a pass's later dispatch windows (pixel.glsl), so not writeonly
layout(std430, binding = B_OUT_COLOR) buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_OUT_STATS) buffer OutStats { PixelStats out_stats[]; };
layout(std430, binding = B_WAVE_STATS) buffer WaveStatsBuffer { WaveStats wave_stats[]; };  // zeroed each frame
// the cell of the technique's structure the pixel read (app.pipeline.passes.OUT_CELL)
layout(std430, binding = B_OUT_CELL) writeonly buffer OutCell { uint out_cell[]; };

// In a later dispatch window (pixel.glsl), the pixel with the sums of the earlier ones.
PixelState resume_pixel(PixelState s) {
    if (!first_window() && s.inside) {
        uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
        s.radiance = out_color[i].rgb;
        s.evaluated = out_stats[i].evaluated;
        s.count = out_stats[i].contrib_count;
        s.hash = out_stats[i].contrib_hash;
        s.nodes = out_stats[i].nodes;
    }
    return s;
}

// Feature variants (app/techniques/variants.py): with VARIANT_TILE (the variant tile in pixels,
// a multiple of the 8x8 group) the pass is one variant's indirect dispatch over its tiles,
// variant_tiles[u_variant_base + gl_WorkGroupID.x] = tx | ty << 16, one group per 8x8 block
// of the tile in y (HDRP builddispatchindirect.compute lists a variant's tiles the same way;
// it counts 8x8 groups in x, this lab tiles, so that the tile count, not the group count,
// meets the 65,535 groups per axis).  Without it, the image's blocks in order, as ever.
// define: VARIANT_TILE
#if defined(VARIANT_TILE) && VARIANT_TILE
layout(std430, binding = B_VARIANT_TILES) readonly buffer VariantTiles { uint variant_tiles[]; };
uniform uint u_variant_base;  // this variant's first entry of variant_tiles

ivec2 group_origin() {
    const uint per = uint(VARIANT_TILE / 8);
    uint t = variant_tiles[u_variant_base + gl_WorkGroupID.x];
    uint sub = gl_WorkGroupID.y;
    return ivec2(int(t & 0xFFFFu), int(t >> 16)) * VARIANT_TILE + ivec2(int(sub % per), int(sub / per)) * 8;
}
#else
ivec2 group_origin() { return ivec2(gl_WorkGroupID.xy) * 8; }
#endif

PixelState load_pixel() { return resume_pixel(load_pixel_at(group_origin() + ivec2(gl_LocalInvocationID.xy))); }

// CELLS_ONLY (app.model: a frame that is modelled, not shaded): the shading pass records
// each pixel's cell (out_cell) and stops there; its light loops do not run.
// define: CELLS_ONLY
#if defined(CELLS_ONLY) && CELLS_ONLY
#define CELLS_ONLY_RETURN(s) { store_pixel(s); return; }
#else
#define CELLS_ONLY_RETURN(s)
#endif

void store_pixel(PixelState s) {
    if (!s.inside) return;
    uint i = uint(s.pixel.y * u_size.x + s.pixel.x);
    out_color[i] = vec4(s.radiance, 1.0);
    out_stats[i].evaluated = s.evaluated;
    out_stats[i].contrib_count = s.count;
    out_stats[i].contrib_hash = s.hash;
    out_stats[i].nodes = s.nodes;
    out_cell[i] = s.cell;
}

// The 8x8 block of the image this group shades (its WAVE_STATS record), in image order.
uint group_index() {
#if defined(VARIANT_TILE) && VARIANT_TILE
    uvec2 g = uvec2(group_origin()) / 8u;
    return g.y * uint((u_size.x + 7) / 8) + g.x;
#else
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
#endif
}

// A variant tile overhanging the image holds groups past its edge: they own no record.
bool group_in_image() { return all(lessThan(group_origin(), u_size)); }

// Wave statistics, per 8x8 group: the longest lane's loop length (the wave's scalar
// iterations) and which traversal case ran (CASE_LIST, CASE_TREE; both = CASE_MIXED; the
// tree techniques add CASE_SHARED_TREE when the group's tree was read from shared memory;
// cpu_prep/layouts.py).
// Global atomics, not a group reduction: barriers are what the emulation pays most for.
void write_wave_stats(uint iterations, uint case_bits) {
    if (!group_in_image()) return;
    uint g = group_index();
    atomicMax(wave_stats[g].iterations, iterations);
    if (case_bits != 0u) atomicOr(wave_stats[g].case_bits, case_bits);
}
