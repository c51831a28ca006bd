// The perfect culler (app/perfect.py): every pixel's exact list of affecting lights, built
// outside the timed region, so that its shading pass times nothing but the shading loop.
//
//   perfect_counts[pixel]           lights affecting the pixel (count pass, whole image)
//   perfect_ranges[band pixel]      (first entry, count) into perfect_entries, band-relative
//   perfect_entries[]               indices into lights[] (visible, depth-sorted)
//
// The image is processed in horizontal bands of whole 8x8 groups (u_row0 = first GL row of
// the band, a multiple of 8) so that the entry list of a band fits one storage block.
// Binding points 10-12 are this module's own (app.features.BINDINGS stops at 9).
#define B_PERFECT_COUNTS 10
#define B_PERFECT_RANGES 11
#define B_PERFECT_ENTRIES 12

uniform int u_row0;

// load_pixel() of common.glsl, for the pixel of this invocation in the current band.
PixelState perfect_load_pixel() {
    PixelState s;
    s.pixel = ivec2(gl_GlobalInvocationID.xy) + ivec2(0, u_row0);
    s.inside = all(lessThan(s.pixel, u_size));
    vec4 pos = s.inside ? texelFetch(g_position, s.pixel, 0) : vec4(0.0);
    s.P = pos.xyz;
    s.depth = pos.w;
    s.shading = s.inside && pos.w > 0.0;
    s.N = s.inside ? texelFetch(g_normal, s.pixel, 0).xyz : vec3(0.0, 0.0, 1.0);
    s.albedo = s.inside ? texelFetch(g_albedo, s.pixel, 0).rgb : vec3(0.0);
    s.radiance = vec3(0.0);
    s.evaluated = 0u; s.count = 0u; s.hash = 0u; s.nodes = 0u;
    return s;
}

// Index of the pixel in the current band (ranges are band-relative).
uint perfect_band_index(PixelState s) {
    return uint((s.pixel.y - u_row0) * u_size.x + s.pixel.x);
}

// group_index() of common.glsl, offset by the band.
uint perfect_group_index() {
    return (gl_WorkGroupID.y + uint(u_row0 / 8)) * uint((u_size.x + 7) / 8) + gl_WorkGroupID.x;
}
