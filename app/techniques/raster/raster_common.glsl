// raster (Drobot 2017): what the tile and the cluster rasterizers' fragment shaders share:
// the proxies, the bit arrays (tiles or clusters x words, bit N = sorted light N), the
// untimed twin's counters and the atomic mark, compacted by wave.glsl's waveCompactValue
// (the slides' WaveCompactValue; helper invocations never the lane that issues an atomic).
// The including shader defines WAVE_FRAGMENT (wave.glsl's fragment stage: the wave*
// functions on the native path only) and COMPACT (RASTER_COMPACT on a native path) to 0 or
// 1; the shader loader writes the native path's #extension lines after #version.
// define: RASTER_STATS
#include "generated.glsl"
#include "wave.glsl"
#include "raster_structs.glsl"

layout(std430, binding = B_RASTER_PROXIES) readonly buffer Proxies { RasterProxy proxies[]; };
layout(std430, binding = B_RASTER_BITS) buffer Bits { uint bits[]; };
#if RASTER_STATS
layout(std430, binding = B_RASTER_STATS_BITS) buffer StatsBits { uint stats_bits[]; };
// x fragments shaded, y atomics issued, z (pixel, light) marks before any merging
layout(std430, binding = B_RASTER_COUNTERS) buffer Counters { uint counters[4]; };
layout(std430, binding = B_RASTER_LIGHT_TILES) buffer LightTiles { uint light_tiles[]; };
#define BITS stats_bits
// Add one a lane to counter k: on the native path one atomic a subgroup, the lowest active
// lane adding the active lanes (its ballot), else one a lane; the same sums either way (helper
// lanes have left before any count).  Atomics on three words from every fragment are most of
// the twin's cost on a CPU rasterizer.
void count_lanes(uint k) {
#if WAVE_NATIVE
    uvec4 lanes = waveBallot(true);
    if (waveCountBelow(lanes) == 0u)
        atomicAdd(counters[k], uint(bitCount(lanes.x) + bitCount(lanes.y) + bitCount(lanes.z) +
                                    bitCount(lanes.w)));
#else
    atomicAdd(counters[k], 1u);
#endif
}
#else
#define BITS bits
#endif

uniform ivec2 u_size;         // full-resolution frame
uniform int u_tile;
uniform ivec2 u_tiles;        // tiles in x and y
uniform uint u_words;
uniform int u_mode;           // RASTER_MODE_* (raster.MODES): the including shader's
uniform int u_step;
uniform ivec2 u_sample_pixel[4];   // MSAA: the full-res pixel of sample k in its 2x2 block
uniform vec2 u_sample_pos[4];       //   and sample k's position in the low-res pixel

flat in uint v_light;

void mark(uint word) {
    uint bit = 1u << (v_light & 31u);
#if COMPACT
    // key: the bit itself (the slides key on the word: lanes of other lights would be lost)
    if (waveCompactValue(word * 32u + (v_light & 31u)) != 0u) return;
#endif
    uint before = atomicOr(BITS[word], bit);
#if RASTER_STATS
    count_lanes(1u);
    if ((before & bit) == 0u) atomicAdd(light_tiles[v_light], 1u);
#endif
}

