// Box lights: the oriented box centred at the position, axes right (right.xyz), up' =
// cross(right, direction) and direction, half extents extent_length.xyz; a point strictly
// inside is affected, lit along the direction with a falloff that reaches zero at the box's
// faces (so the volume is the bound, and radius is ignored).  d = P - position.

vec3 box_local(GpuLight L, vec3 d) {
    vec3 r = L.right.xyz, f = L.dir_cos_outer.xyz;
    vec3 u = cross(r, f);
    precise vec3 p = vec3(dot(d, r), dot(d, u), dot(d, f));
    return p;
}

bool box_contains(GpuLight L, vec3 d) {
    precise vec3 p = box_local(L, d);
    return all(lessThan(abs(p), L.extent_length.xyz));
}

vec3 box_radiance(GpuLight L, vec3 d, vec3 N, out vec3 l) {
    l = -L.dir_cos_outer.xyz;
    vec3 m = abs(box_local(L, d)) / max(L.extent_length.xyz, vec3(1e-30));
    float e = max(max(m.x, m.y), m.z);
    float w = clamp(1.0 - e * e * e * e, 0.0, 1.0);
    return L.color_cos_inner.rgb * max(dot(N, -L.dir_cos_outer.xyz), 0.0) * w * w;
}
