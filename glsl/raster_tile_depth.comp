#version 450
// raster (stats only, untimed): each tile's min / max scene depth as float bits, x holding
// the complement of the min so that a zeroed buffer starts both (y 0: no geometry), so the
// meta can tell the lights occlusion alone removed from those a tile depth-bounds test
// would remove too.
layout(local_size_x = 8, local_size_y = 8) in;
layout(binding = 0) uniform sampler2D g_position;
layout(std430, binding = B_RASTER_TILE_DEPTH) buffer TileDepth { uvec2 tile_depth[]; };
uniform ivec2 u_size;
uniform int u_tile;
uniform int u_tiles_x;

void main() {
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, u_size))) return;
    float d = texelFetch(g_position, pixel, 0).w;
    if (d <= 0.0) return;
    ivec2 t = pixel / u_tile;
    uint i = uint(t.y * u_tiles_x + t.x);
    atomicMax(tile_depth[i].x, ~floatBitsToUint(d));
    atomicMax(tile_depth[i].y, floatBitsToUint(d));
}
