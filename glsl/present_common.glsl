// What a person sees, defined once: the GLSL twins of app/images.py (display, tonemap, the
// heat ramp and scale, the luminance histogram's bins).  tests/app/window/test_present.py
// runs these against the Python functions.  Constants come from app/images.py as defines
// (app/window/passes.py present_defines), so the numbers are written there only.
// define: HIST_BINS HIST_LOG2_MIN HIST_LOG2_MAX HEAT_ZERO HEAT_OVERLAY_ALPHA

const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);

// Reinhard x / (1 + x), gamma 1/2.2 (images.tonemap_float).
vec3 tonemap(vec3 x) {
    x = max(x, vec3(0.0));
    return pow(x / (1.0 + x), vec3(1.0 / 2.2));
}

// The shaded image as shown (images.display): exposure on the lights' radiance, then a
// faint ambient floor of the albedo.
vec3 display(vec3 radiance, vec3 albedo, float exposure, float ambient) {
    return tonemap(exposure * radiance + ambient * albedo);
}

// Bin of luminance y > 0 in the log2 histogram (images.hist_bin).
int hist_bin(float y) {
    float scale = float(HIST_BINS) / (float(HIST_LOG2_MAX) - float(HIST_LOG2_MIN));
    float b = floor((log2(y) - float(HIST_LOG2_MIN)) * scale);
    return int(clamp(b, 0.0, float(HIST_BINS - 1)));
}

// Turbo colour ramp (Mikhailov 2019, polynomial fit), t in [0, 1] (images.turbo).
vec3 turbo(float t) {
    t = clamp(t, 0.0, 1.0);
    const vec4 kr = vec4(0.13572138, 4.61539260, -42.66032258, 132.13108234);
    const vec4 kg = vec4(0.09140261, 2.19418839, 4.84296658, -14.18503333);
    const vec4 kb = vec4(0.10667330, 12.64194608, -60.58204836, 110.36276771);
    const vec2 kr2 = vec2(-152.94239396, 59.28637943);
    const vec2 kg2 = vec2(4.27729857, 2.82956604);
    const vec2 kb2 = vec2(-89.90310912, 27.34824973);
    vec4 v4 = vec4(1.0, t, t * t, t * t * t);
    vec2 v2 = v4.zw * v4.z;
    return clamp(vec3(dot(v4, kr) + dot(v2, kr2), dot(v4, kg) + dot(v2, kg2),
                      dot(v4, kb) + dot(v2, kb2)), 0.0, 1.0);
}

// The heat scale (images.heat_t): log2(1 + n) / log2(1 + max).
float heat_t(float n, float vmax) {
    return clamp(log2(1.0 + max(n, 0.0)) / log2(1.0 + max(vmax, 1.0)), 0.0, 1.0);
}

// One pixel of the heat map (images.heat_rgb): sky black, a covered zero grey.
vec3 heat_color(uint n, float vmax, bool covered) {
    if (!covered) return vec3(0.0);
    if (n == 0u) return vec3(HEAT_ZERO);
    return turbo(heat_t(float(n), vmax));
}
