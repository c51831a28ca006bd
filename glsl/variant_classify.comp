#version 430
// Feature variants, step 2 (app/techniques/variants.py): each variant tile's feature mask,
// the OR over its shading pixels of their cell's bits (variant_cells.comp) and their
// material's (FEATURE_SPECULAR_BIT: roughness > 0, the pixels GGX runs for), as HDRP ORs
// each 16x16 tile's light and material feature flags (LightDefinitions.cs FeatureFlags).
// A tile of sky keeps mask 0 (empty): it is still dispatched, to write its pixels.
// With PIXEL_FEATURES (the figures only, untimed) each pixel's own bits instead, the top bit
// set where it shades: what its program compiled that it did not need is counted from them.
// define: VARIANT_TILE PIXEL_FEATURES PIXEL_SHADES
#include "generated.glsl"
#include "pixel.glsl"
#include "cells.glsl"

layout(std430, binding = B_CELL_FEATURES) readonly buffer CellFeatures { uint cell_features[]; };
#if PIXEL_FEATURES
layout(std430, binding = B_PIXEL_FEATURES) writeonly buffer PixelFeatures { uint pixel_features[]; };
#else
layout(std430, binding = B_TILE_MASKS) buffer TileMasks { uint tile_masks[]; };   // zeroed
uniform int u_variant_tiles_x;
shared uint s_mask;
#endif

// priced: depth
void main() {
    PixelState s = load_pixel_at(ivec2(gl_GlobalInvocationID.xy));
    uint bits = 0u;
    if (s.shading) {
        bits = cell_features[cell_of(s)];
        if (s.roughness > 0.0) bits |= FEATURE_SPECULAR_BIT;
    }
#if PIXEL_FEATURES
    if (s.inside) pixel_features[s.pixel.y * u_size.x + s.pixel.x] = bits | (s.shading ? PIXEL_SHADES : 0u);
#else
    if (gl_LocalInvocationIndex == 0u) s_mask = 0u;
    barrier();
    if (bits != 0u) atomicOr(s_mask, bits);
    barrier();
    if (gl_LocalInvocationIndex == 0u && s_mask != 0u) {
        ivec2 t = ivec2(gl_WorkGroupID.xy) * 8 / VARIANT_TILE;   // the group lies in one tile
        atomicOr(tile_masks[t.y * u_variant_tiles_x + t.x], s_mask);
    }
#endif
}
