// The depth slice of a view depth: tree paper listing 4 with the scale corrected
// (cpu_prep.grid builds the same slices on the CPU).  One function for the list techniques'
// shading, the cluster rasterizer's marking and shading, so that a pixel's slice is always
// the one its lights were binned or marked into.
uniform int u_slices;
uniform float u_slice_scale;  // (S - 1) / (logMax - logMin)
uniform float u_slice_bias;   // 1 - logMin * scale

uint slice_of(float depth) {
    float slice = max(log(max(depth, 1e-30)) * u_slice_scale + u_slice_bias, 0.0);
    return uint(min(int(slice), u_slices - 1));
}
