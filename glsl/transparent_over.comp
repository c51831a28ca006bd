#version 430
// Composite one transparent layer over the frame's colour (app/pipeline/transparent.py), layers in
// turn from the back: colour = opacity * layer + (1 - opacity) * colour where the layer has a
// fragment (opacity 0 where it has none: the colour stays as it was).
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = B_OUT_COLOR) buffer OutColor { vec4 out_color[]; };
layout(std430, binding = B_LAYER_COLOR) readonly buffer LayerColor { vec4 layer_color[]; };
uniform sampler2D u_opacity;
uniform ivec2 u_size;
uniform uint u_offset;       // the layer's first pixel in layer_color

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, u_size))) return;
    uint i = uint(p.y * u_size.x + p.x);
    float a = texelFetch(u_opacity, p, 0).r;
    if (a > 0.0) out_color[i].rgb = mix(out_color[i].rgb, layer_color[u_offset + i].rgb, a);
}
