#version 430
// The window's feature-variant view (app/window/variant_view.py): each variant tile tinted
// by its program's colour (alpha-blended over the shaded image the present pass drew), its
// border dark so that neighbouring tiles of one program still read as tiles.
in vec2 v_uv;
out vec4 frag;

layout(std430, binding = B_VARIANT_VIEW) readonly buffer TileColors { vec4 tile_colors[]; };

uniform ivec2 u_size;           // the frame
uniform ivec2 u_viewport;       // the target's drawn size
uniform int u_variant_tile;     // px
uniform int u_variant_tiles_x;

void main() {
    ivec2 p = min(ivec2(floor(gl_FragCoord.xy * vec2(u_size) / vec2(u_viewport))), u_size - 1);
    ivec2 t = p / u_variant_tile;
    ivec2 q = p - t * u_variant_tile;
    bool edge = q.x == 0 || q.y == 0;
    frag = edge ? vec4(0.0, 0.0, 0.0, 0.7) : tile_colors[t.y * u_variant_tiles_x + t.x];
}
