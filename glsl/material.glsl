// The surface's response to light arriving from direction l (unit, towards the light), as a
// factor of the light functions' arriving term (which already holds the cosine): the albedo
// for a matte surface; with SPECULAR (features.glsl: some surface of the scene has roughness
// > 0), GGX specular (Trowbridge-Reitz D, Smith-Schlick G with k = a/2, Schlick F; F0 0.04,
// or the albedo for metals) on the diffuse part, both scaled by pi like the Lambert term.
// A scene whose surfaces are all matte compiles none of it.

const float MATERIAL_PI = 3.14159265;

vec3 surface_response(vec3 N, vec3 V, vec3 l, vec3 albedo, float roughness, float metallic) {
#if SPECULAR
    if (roughness > 0.0) {
        vec3 H = normalize(l + V);
        float nl = max(dot(N, l), 1e-4), nv = max(dot(N, V), 1e-4);
        float nh = max(dot(N, H), 0.0), vh = max(dot(V, H), 0.0);
        float a = roughness * roughness, a2 = a * a;
        float q = nh * nh * (a2 - 1.0) + 1.0;
        float D = a2 / (MATERIAL_PI * q * q);
        float k = 0.5 * a;
        float G = nl / (nl * (1.0 - k) + k) * nv / (nv * (1.0 - k) + k);
        vec3 F0 = mix(vec3(0.04), albedo, metallic);
        vec3 F = F0 + (1.0 - F0) * pow(1.0 - vh, 5.0);
        return albedo * (1.0 - metallic) * (1.0 - F) + MATERIAL_PI * D * G * F / (4.0 * nl * nv);
    }
#endif
    return albedo;
}
