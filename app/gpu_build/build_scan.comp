#version 430
// Exclusive prefix sum of u_n uint words, src -> dst, in three steps (app/gpu_build/steps.py):
//   SCAN_STEP 0  each block of SCAN_BLOCK words: its exclusive scan, and its total in sums[]
//   SCAN_STEP 1  one group: the exclusive scan of sums[] (in place), the grand total into
//                counters[u_total_word] (0xFFFFFFFF: kept nowhere)
//   SCAN_STEP 2  each block adds its scanned sum
// Integer sums, so any order gives the CPU's np.cumsum bit for bit.
// define: SCAN_STEP
#include "build_common.glsl"

const uint PER_THREAD = 4u;
const uint SCAN_BLOCK = GROUP * PER_THREAD;

uniform uint u_n;
uniform uint u_blocks;
uniform uint u_total_word;

#if SCAN_STEP == 0
layout(std430, binding = B_SRC) readonly buffer Src { uint src[]; };
#endif
#if SCAN_STEP != 1
layout(std430, binding = B_DST) buffer Dst { uint dst[]; };
#endif
#if SCAN_STEP == 2
layout(std430, binding = B_SUMS) readonly buffer Sums { uint sums[]; };
#else
layout(std430, binding = B_SUMS) buffer Sums { uint sums[]; };
#endif
#if SCAN_STEP == 1
layout(std430, binding = B_COUNTERS) buffer Counters { uint counters[]; };
#endif

shared uint partial[GROUP];

// Exclusive scan of one value a thread over the group (Hillis-Steele); returns the group total.
uint group_scan(inout uint v) {
    uint lid = gl_LocalInvocationID.x;
    partial[lid] = v;
    barrier();
    for (uint d = 1u; d < GROUP; d <<= 1) {
        uint add = lid >= d ? partial[lid - d] : 0u;
        barrier();
        partial[lid] += add;
        barrier();
    }
    uint total = partial[GROUP - 1u];
    v = partial[lid] - v;
    barrier();
    return total;
}

#if SCAN_STEP == 0
void main() {
    uint block = group_index();
    if (block >= u_blocks) return;           // (whole groups: no barrier is skipped by half a group)
    uint base = block * SCAN_BLOCK + gl_LocalInvocationID.x * PER_THREAD;
    uint v[PER_THREAD];
    uint run = 0u;
    for (uint k = 0u; k < PER_THREAD; ++k) {
        v[k] = base + k < u_n ? src[base + k] : 0u;
        run += v[k];
    }
    uint before = run;
    uint total = group_scan(before);
    for (uint k = 0u; k < PER_THREAD; ++k) {
        if (base + k < u_n) dst[base + k] = before;
        before += v[k];
    }
    if (gl_LocalInvocationID.x == 0u) sums[block] = total;
}
#elif SCAN_STEP == 1
void main() {
    uint carry = 0u;
    for (uint chunk = 0u; chunk * SCAN_BLOCK < u_blocks; ++chunk) {
        uint base = chunk * SCAN_BLOCK + gl_LocalInvocationID.x * PER_THREAD;
        uint v[PER_THREAD];
        uint run = 0u;
        for (uint k = 0u; k < PER_THREAD; ++k) {
            v[k] = base + k < u_blocks ? sums[base + k] : 0u;
            run += v[k];
        }
        uint before = run;
        uint total = group_scan(before);
        before += carry;
        for (uint k = 0u; k < PER_THREAD; ++k) {
            if (base + k < u_blocks) sums[base + k] = before;
            before += v[k];
        }
        carry += total;
    }
    if (gl_LocalInvocationID.x == 0u && u_total_word != 0xFFFFFFFFu) counters[u_total_word] = carry;
}
#else
void main() {
    uint block = group_index();
    if (block >= u_blocks) return;
    uint base = block * SCAN_BLOCK + gl_LocalInvocationID.x * PER_THREAD;
    uint add = sums[block];
    for (uint k = 0u; k < PER_THREAD; ++k)
        if (base + k < u_n) dst[base + k] += add;
}
#endif
