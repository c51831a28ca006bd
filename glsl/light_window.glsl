// Finite-window attenuation (docs/contracts.md "Light model"): (1 - (d/r)^4)^2 / (d^2 + 1), zero
// outside the volume, so culling at the radius is exact.
// With UNBOUNDED_FALLOFF (the benchmark's no-cutoff reference) the window is dropped and
// every light reaches every point: 1 / (d^2 + 1).
// Stochastic light culling (Tokuyoshi & Harada 2016; cpu_prep/stochastic.py): a light with
// alpha > 0 (GPU_LIGHT right.w; 0 by default and for box lights) has its range r drawn on
// the CPU by Russian roulette, and inside it the unbounded falloff divided by the evaluation
// probability p = min(f/alpha, 1): f/p = max(alpha, 1/(d^2 + 1)), so that the frame is an
// unbiased estimate of the UNBOUNDED_FALLOFF image.  Outside r nothing (sphere_reaches).
// define: UNBOUNDED_FALLOFF
float window_attenuation(float d2, float r, float alpha) {
#if defined(UNBOUNDED_FALLOFF) && UNBOUNDED_FALLOFF
    return 1.0 / (d2 + 1.0);
#endif
    if (alpha > 0.0) return max(alpha, 1.0 / (d2 + 1.0));
    float x2 = d2 / (r * r);
    float w = clamp(1.0 - x2 * x2, 0.0, 1.0);
    return w * w / (d2 + 1.0);
}

// Light arriving at the surface from a point at offset -d (times the surface's response,
// material.glsl); l: the unit direction towards the light.
vec3 lambert(GpuLight L, vec3 d, float d2, vec3 N, out vec3 l) {
    l = -d * inversesqrt(max(d2, 1e-30));
    return L.color_cos_inner.rgb * max(dot(N, l), 0.0) * window_attenuation(d2, L.pos_radius.w, L.right.w);
}

// Inside the light's sphere (point and spot lights; every point with UNBOUNDED_FALLOFF).
bool sphere_reaches(GpuLight L, float d2) {
#if defined(UNBOUNDED_FALLOFF) && UNBOUNDED_FALLOFF
    return true;
#else
    return d2 < L.pos_radius.w * L.pos_radius.w;
#endif
}
