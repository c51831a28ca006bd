#version 430
// zbin (Drobot 2017, "Improved Culling for Tiled and Clustered Rendering"): a flat bit array
// per screen tile (bit N = light N of the depth-sorted list) and a Z-bin LUT of the min/max
// light id per uniform depth bin.  The four rows of the slides' "F+ Renderer: Optimization
// Performance" table:
//   ZBIN_MASKED 0, SCALARIZED 0   base tile: each lane walks its tile's words and bits
//   ZBIN_MASKED 1, SCALARIZED 0   tile + zbin: wave-uniform word range from the lanes' z-bin
//                                 min/max, each lane's words masked by its own z-bin range
//   ZBIN_MASKED 0, SCALARIZED 1   scalarized tile: words merged over the wave (waveAllBitOr),
//                                 one scalar loop over the merged bits
//   ZBIN_MASKED 1, SCALARIZED 1   scalarized tile + zbin: the slides' final listing
// Dispatch windows (pixel.glsl): a pixel's sequence position of light N is N itself, so a
// window [lo, hi) takes the words of lights lo..hi-1 and masks the bits outside it.
// Wave statistics (8x8 group): iterations = the wave's loop iterations (scalarized: the merged
// loop; per lane: its longest lane), lane_loops.x = sum over lanes of each lane's own bits (the
// per-lane loop's iterations), lane_loops.y = the longest lane's own bits (per dispatch window).
// define: ZBIN_MASKED SCALARIZED ZBIN_WIDE ZBIN_EMPTY_MIN ZBIN_PRINTED_MASK
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
#include "zbin_mask.glsl"

layout(std430, binding = B_TILE_BITS) readonly buffer TileBits { uint tile_bits[]; };
#if ZBIN_MASKED
#if ZBIN_WIDE
// past 65,536 visible lights: 2 x 32-bit (min, max) per bin (cpu_prep.zbin)
layout(std430, binding = B_ZBINS) readonly buffer ZBins { uvec2 zbins[]; };
#else
// the slides' 2 x 16-bit entry: MIN | MAX << 16; empty bins MAX_ID | 0
layout(std430, binding = B_ZBINS) readonly buffer ZBins { uint zbins[]; };
#endif
#endif

uniform int u_tile;           // bit-array tile, pixels (after the memory budget)
uniform ivec2 u_tiles;       // tiles in x and y
uniform uint u_words;         // words per tile: ceil(visible lights / 32)
uniform uint u_bins;
uniform float u_bin_scale;    // bins per metre of view depth

#if WAVE_NATIVE
// the listing's WaveReadFirstLane: the wave-uniform value into a scalar register
#define SCALAR(x) waveReadFirstLane(x)
#else
// the emulated reductions already return group-uniform values; reading lane 0 again would
// only add a round of barriers
#define SCALAR(x) (x)
#endif

// The pixel's z-bin.
// priced: cell
uint zbin_of(float depth) { return uint(min(depth * u_bin_scale, float(u_bins - 1u))); }

// (min id, max id) of z-bin `bin`; min > max: no light in the bin.
// priced: cell
uvec2 zbin_range(uint bin) {
#if ZBIN_MASKED
#if ZBIN_WIDE
    return zbins[bin];
#else
    uint data = zbins[bin];
    return uvec2(data & 0xFFFFu, data >> 16);
#endif
#else
    return uvec2(0u, 0xFFFFFFFFu);
#endif
}

// Each lane's Z-bin mask of word `wordIndex`.  The listing as printed (ZBIN_PRINTED_MASK)
// clamps the start to the word but takes the width of the whole range: it leaks bit 31 of
// the words before the range, the tail of its last word, and once the range is 32 or wider
// the whole of every word, the first's head too (more evaluations, still exact:
// cpu_prep.zbin.zbin_word_mask); the default masks exactly the lights min..max.
uint zbin_word_mask(uint minIdx, uint maxIdx, uint wordIndex) {
#if ZBIN_PRINTED_MASK
    uint localMin = uint(clamp(int(minIdx) - int(wordIndex * 32u), 0, 31));
    uint maskWidth = uint(clamp(int(maxIdx) - int(minIdx) + 1, 0, 32));
    // BitFieldMask op needs manual 32 size wrap support
    return maskWidth == 32u ? 0xFFFFFFFFu : BitFieldMask(maskWidth, localMin);
#else
    return range_mask(minIdx, maxIdx, wordIndex);
#endif
}

// One lane's word `w`: its tile's bits (loaded per lane), masked by its z-bin range and by
// the dispatch window; none for lanes that shade nothing.
uint lane_word(bool shading, uint address, uint minIdx, uint maxIdx, uint w) {
    uint mask = shading ? tile_bits[address + w] : 0u;
#if ZBIN_MASKED
    mask &= zbin_word_mask(minIdx, maxIdx, w);      // mask by ZBin mask
#endif
    return mask & window_mask(w);
}

void main() {
    PixelState s = load_pixel();
    ivec2 t = s.pixel / u_tile;
    uint address = s.shading ? uint(t.y * u_tiles.x + t.x) * u_words : 0u;
#if ZBIN_MASKED
    if (s.shading) s.cell = zbin_of(s.depth);
#endif
    CELLS_ONLY_RETURN(s);
    uvec2 zr = s.shading ? zbin_range(s.cell) : uvec2(uint(ZBIN_EMPTY_MIN), 0u);
    uint minIdx = zr.x, maxIdx = zr.y;

    // words of this window: [wordMin, wordEnd)
    uint wordMin = u_window.x / 32u;
    uint wordEnd = min(u_words, u_window.y / 32u + ((u_window.y & 31u) != 0u ? 1u : 0u));
#if ZBIN_MASKED
    uint mergedMin = SCALAR(waveAllMin(minIdx));   // mergedMin scalar from this point
    uint mergedMax = SCALAR(waveAllMax(maxIdx));   // mergedMax scalar from this point
    wordMin = max(mergedMin / 32u, wordMin);
    wordEnd = min(mergedMax / 32u + 1u, wordEnd);
#endif
    uint own = 0u;       // this lane's own bits: the per-lane loop's iterations

#if SCALARIZED
#if WAVE_NATIVE
    // the slides' final listing, word by word
    // priced: word
    for (uint wordIndex = wordMin; wordIndex < wordEnd; ++wordIndex) {
        uint mask = lane_word(s.shading, address, minIdx, maxIdx, wordIndex);
        own += uint(bitCount(mask));
        uint mergedMask = SCALAR(waveAllBitOr(mask));        // compact word bitmask over the wave
        // priced: light
        while (mergedMask != 0u) {                           // processed scalar over merged bitmask
            uint bitIndex = uint(findLSB(mergedMask));
            mergedMask ^= 1u << bitIndex;
            if (s.shading) evaluate_light(s, lights[32u * wordIndex + bitIndex]);
        }
    }
#else
    // the same loop with the emulated wave's WaveAllBitOr done for WAVE_OR_WORDS words per
    // round of barriers (wave.glsl groupOrWords*): the same merged words, in order
    // priced: word
    for (uint chunk = wordMin; chunk < wordEnd; chunk += uint(WAVE_OR_WORDS)) {
        uint count = min(uint(WAVE_OR_WORDS), wordEnd - chunk);
        groupOrWordsBegin(count);
        for (uint k = 0u; k < count; ++k) {
            uint mask = lane_word(s.shading, address, minIdx, maxIdx, chunk + k);
            own += uint(bitCount(mask));
            groupOrWord(k, mask);
        }
        groupOrWordsEnd();
        for (uint k = 0u; k < count; ++k) {
            uint wordIndex = chunk + k;
            uint mergedMask = groupOrWordsResult(k);
            // priced: light
            while (mergedMask != 0u) {
                uint bitIndex = uint(findLSB(mergedMask));
                mergedMask ^= 1u << bitIndex;
                if (s.shading) evaluate_light(s, lights[32u * wordIndex + bitIndex]);
            }
        }
    }
#endif
    uint wave_iterations = s.evaluated;    // every shading lane runs the whole merged loop
#else
    if (s.shading) {
        // priced: word
        for (uint wordIndex = wordMin; wordIndex < wordEnd; ++wordIndex) {
            uint mask = lane_word(true, address, minIdx, maxIdx, wordIndex);
            own += uint(bitCount(mask));
            // priced: light
            while (mask != 0u) {                             // processed per lane
                uint bitIndex = uint(findLSB(mask));
                mask ^= 1u << bitIndex;
                evaluate_light(s, lights[32u * wordIndex + bitIndex]);
            }
        }
    }
    uint wave_iterations = s.evaluated;    // the wave runs as long as its longest lane
#endif
    store_pixel(s);
    write_wave_stats(wave_iterations, CASE_LIST);
    if (own != 0u) {
        uint g = group_index();
        atomicAdd(wave_stats[g].lane_loops.x, own);
        atomicMax(wave_stats[g].lane_loops.y, own);
    }
}
