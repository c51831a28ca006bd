// Capsule (tube) lights: the segment centred at the position, along the direction,
// extent_length.w long; a point is affected within the radius of the segment, and lit from
// the segment's nearest point with the point light's falloff.
// d = P - position.

vec3 capsule_offset(GpuLight L, vec3 d) {
    precise float h = 0.5 * L.extent_length.w;
    precise float t = clamp(dot(d, L.dir_cos_outer.xyz), -h, h);
    precise vec3 q = d - L.dir_cos_outer.xyz * t;
    return q;
}

bool capsule_contains(GpuLight L, vec3 d) {
    precise vec3 q = capsule_offset(L, d);
    precise float q2 = dot(q, q);
    return sphere_reaches(L, q2);
}

vec3 capsule_radiance(GpuLight L, vec3 d, vec3 N, out vec3 l) {
    vec3 q = capsule_offset(L, d);
    return lambert(L, q, dot(q, q), N, l);
}
