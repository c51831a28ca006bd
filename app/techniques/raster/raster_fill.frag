#version 450
// raster: the scene's depth into the technique's own depth target, from the G-buffer's
// linear depth d (the P every shading pass tests): reversed depth with the far plane at
// infinity, window depth = near / d (raster_proxy.vert), 0 where no geometry (farthest),
// 1 past the frame's edge (nearest: no proxy passes in front of it).
//   RASTER_MSAA  half resolution, 4 samples: sample k holds the full-resolution pixel of its
//                quadrant (u_sample_pixel; gl_SampleID makes the pass run per sample), as a
//                console aliases a full-resolution depth buffer as a 4xMSAA one.
// define: RASTER_MSAA
#include "generated.glsl"
layout(binding = G_POSITION_UNIT) uniform sampler2D g_position;
uniform ivec2 u_size;
uniform float u_near;
uniform ivec2 u_sample_pixel[4];

// priced: fragment
void main() {
#if RASTER_MSAA
    ivec2 pixel = ivec2(gl_FragCoord.xy) * 2 + u_sample_pixel[gl_SampleID];
#else
    ivec2 pixel = ivec2(gl_FragCoord.xy);
#endif
    if (any(greaterThanEqual(pixel, u_size))) {
        gl_FragDepth = 1.0;
        return;
    }
    float d = texelFetch(g_position, pixel, 0).w;
    gl_FragDepth = d > 0.0 ? clamp(u_near / d, 0.0, 1.0) : 0.0;
}
