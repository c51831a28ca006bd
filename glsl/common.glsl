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

PixelState load_pixel() { return resume_pixel(load_pixel_at(ivec2(gl_GlobalInvocationID.xy))); }

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

uint group_index() {
    return gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
}

// Wave statistics, per 8x8 group: the longest lane's loop length (the wave's scalar
// iterations) and which traversal case ran (CASE_LIST, CASE_TREE; both = CASE_MIXED; the
// tree techniques add CASE_SHARED_TREE when the group's tree was read from shared memory;
// cpu_prep/layouts.py).
// Global atomics, not a group reduction: barriers are what the emulation pays most for.
void write_wave_stats(uint iterations, uint case_bits) {
    uint g = group_index();
    atomicMax(wave_stats[g].iterations, iterations);
    if (case_bits != 0u) atomicOr(wave_stats[g].case_bits, case_bits);
}
