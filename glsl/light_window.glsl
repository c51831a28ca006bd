// Finite-window attenuation (DESIGN "Light model"): (1 - (d/r)^4)^2 / (d^2 + 1), zero
// outside the volume, so culling at the radius is exact.
float window_attenuation(float d2, float r) {
    float x2 = d2 / (r * r);
    float w = clamp(1.0 - x2 * x2, 0.0, 1.0);
    return w * w / (d2 + 1.0);
}

vec3 lambert(GpuLight L, vec3 d, float d2, vec3 N) {
    vec3 l = -d * inversesqrt(max(d2, 1e-30));
    return L.color_cos_inner.rgb * max(dot(N, l), 0.0) * window_attenuation(d2, L.pos_radius.w);
}
