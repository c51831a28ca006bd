// Spot lights: the sphere cut by the cone of cos_outer, smooth falloff to cos_inner.
bool spot_cone_contains(GpuLight L, vec3 d, float d2) {
    precise float along = dot(d, L.dir_cos_outer.xyz);
    precise float edge = L.dir_cos_outer.w * sqrt(d2);
    return along > edge;
}

float spot_falloff(GpuLight L, vec3 d, float d2) {
    float c = dot(d, L.dir_cos_outer.xyz) * inversesqrt(max(d2, 1e-30));
    float lo = L.dir_cos_outer.w, hi = L.color_cos_inner.w;
    // inner == outer is a hard edge (smoothstep is undefined for equal edges)
    return hi > lo ? smoothstep(lo, hi, c) : 1.0;
}
