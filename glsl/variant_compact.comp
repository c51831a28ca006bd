#version 430
// Feature variants, step 3 (app/techniques/variants.py), HDRP's builddispatchindirect.compute:
// each variant tile appended to the list of its mask, variant_tiles[mask * u_variant_tiles +
// k] = tx | ty << 16, and that mask's DispatchIndirectCommand counted up, x = its tiles,
// y = the 8x8 groups of a tile, z = 1 (HDRP counts 4 groups a 16x16 tile in x; here y holds
// them, so that only the tile count meets the 65,535 groups per axis).  Every tile is
// listed, empty ones too: none is skipped (HDRP skips sky tiles, which write nothing there).
// define: VARIANT_TILE
#include "generated.glsl"

layout(local_size_x = 64) in;

layout(std430, binding = B_TILE_MASKS) readonly buffer TileMasks { uint tile_masks[]; };
layout(std430, binding = B_VARIANT_ARGS) buffer VariantArgs { uint variant_args[]; };   // zeroed
layout(std430, binding = B_VARIANT_TILES) writeonly buffer VariantTiles { uint variant_tiles[]; };

uniform uint u_variant_tiles;   // variant tiles of the frame
uniform int u_variant_tiles_x;

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t == 0u) {
        const uint per = uint(VARIANT_TILE / 8);
        // priced: load
        for (uint m = 0u; m < FEATURE_MASKS; ++m) {
            variant_args[3u * m + 1u] = per * per;
            variant_args[3u * m + 2u] = 1u;
        }
    }
    if (t >= u_variant_tiles) return;
    uint mask = tile_masks[t];
    uint k = atomicAdd(variant_args[3u * mask], 1u);
    uint tx = t % uint(u_variant_tiles_x);
    variant_tiles[mask * u_variant_tiles + k] = tx | ((t / uint(u_variant_tiles_x)) << 16);
}
