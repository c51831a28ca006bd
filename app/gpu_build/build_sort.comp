#version 430
// One digit of a stable LSD radix sort of (key, value) pairs (app/gpu_build/steps.py):
//   SORT_STEP 0  per block of 256 pairs, how many have each digit: hist[digit * blocks + block]
//   (the histogram then goes through build_scan.comp: digit-major, so its exclusive scan is
//    each (digit, block)'s first place in the output)
//   SORT_STEP 1  each pair to its digit's place, after the pairs of its block with that digit
//                that come before it: stable, so ties keep their input order
// The pair count is counters[u_count_word] (made on the GPU: the visible lights, the entries).
// define: SORT_STEP
#include "build_common.glsl"

uniform uint u_shift;
uniform uint u_blocks;
uniform uint u_count_word;

const uint DIGITS = 256u;

layout(std430, binding = B_COUNTERS) readonly buffer Counters { uint counters[]; };
layout(std430, binding = B_SRC_KEYS) readonly buffer SrcKeys { uint src_keys[]; };
#if SORT_STEP == 0
layout(std430, binding = B_HIST) buffer Hist { uint hist[]; };
shared uint counts[DIGITS];
#else
layout(std430, binding = B_SRC_VALUES) readonly buffer SrcValues { uint src_values[]; };
layout(std430, binding = B_HIST) readonly buffer Hist { uint hist[]; };
layout(std430, binding = B_DST_KEYS) buffer DstKeys { uint dst_keys[]; };
layout(std430, binding = B_DST_VALUES) buffer DstValues { uint dst_values[]; };
// per digit, which of the block's 256 pairs have it: 8 words a digit (8 KiB)
const uint MASK_WORDS = GROUP / 32u;
shared uint holders[DIGITS * MASK_WORDS];
#endif

void main() {
    uint block = group_index();
    if (block >= u_blocks) return;
    uint lid = gl_LocalInvocationID.x;
    uint e = block * GROUP + lid;
    bool valid = e < counters[u_count_word];
    uint key = valid ? src_keys[e] : 0u;
    uint digit = valid ? (key >> u_shift) & (DIGITS - 1u) : DIGITS;   // DIGITS: no pair
#if SORT_STEP == 0
    counts[lid] = 0u;                       // (GROUP == DIGITS)
    barrier();
    if (valid) atomicAdd(counts[digit], 1u);
    barrier();
    hist[lid * u_blocks + block] = counts[lid];
#else
    // the pair's rank among its block's pairs with its digit that come before it: the set
    // bits below its own in its digit's mask (8 popcounts, not a loop over 256 pairs)
    for (uint w = 0u; w < MASK_WORDS; ++w) holders[lid * MASK_WORDS + w] = 0u;   // (GROUP == DIGITS)
    barrier();
    uint word = lid >> 5, bit = 1u << (lid & 31u);
    if (valid) atomicOr(holders[digit * MASK_WORDS + word], bit);
    barrier();
    if (!valid) return;
    uint rank = bitCount(holders[digit * MASK_WORDS + word] & (bit - 1u));
    for (uint w = 0u; w < word; ++w) rank += bitCount(holders[digit * MASK_WORDS + w]);
    uint at = hist[digit * u_blocks + block] + rank;
    dst_keys[at] = key;
    dst_values[at] = src_values[e];
#endif
}
