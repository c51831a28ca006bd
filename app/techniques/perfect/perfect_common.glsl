// The perfect culler (app/techniques/perfect.py): every pixel's exact list of affecting lights, built
// outside the timed region, so that its shading pass times nothing but the shading loop.
//
//   perfect_counts[pixel]           lights affecting the pixel (count pass, whole image)
//   perfect_ranges[band pixel]      (first entry, count) into perfect_entries, band-relative
//   perfect_entries[]               indices into lights[] (visible, depth-sorted)
//
// The image is processed in horizontal bands of whole 8x8 groups (u_row0 = first GL row of
// the band, a multiple of 8) so that the entry list of a band fits one storage block.

uniform int u_row0;

// load_pixel() of common.glsl, for the pixel of this invocation in the current band.
PixelState perfect_load_pixel() {
    return load_pixel_at(ivec2(gl_GlobalInvocationID.xy) + ivec2(0, u_row0));
}

// Index of the pixel in the current band (ranges are band-relative).
// priced: cell
uint perfect_band_index(PixelState s) {
    return uint((s.pixel.y - u_row0) * u_size.x + s.pixel.x);
}

// group_index() of common.glsl, offset by the band.
uint perfect_group_index() {
    return (gl_WorkGroupID.y + uint(u_row0 / 8)) * uint((u_size.x + 7) / 8) + gl_WorkGroupID.x;
}
