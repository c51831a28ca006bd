#version 430
// One transparent layer by depth peeling (app/pipeline/transparent.py): of the transparent fragments
// strictly in front of the opaque surface (u_opaque.w; 0 = sky, nothing to be in front of) and
// strictly behind the previous layer's (u_front.w; layer 0 has none), the nearest (the depth
// test).  Its targets are the G-buffer's formats, so every technique's passes read a layer
// exactly as they read the opaque G-buffer, plus the fragment's opacity.
uniform sampler2D u_opaque;
uniform sampler2D u_front;
uniform int u_layer;
in vec3 v_view;
in vec3 v_normal;
in vec3 v_albedo;
flat in vec2 v_material;
flat in float v_opacity;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;
layout(location = 3) out vec4 out_opacity;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float d = -v_view.z;
    float opaque = texelFetch(u_opaque, px, 0).w;
    if (opaque > 0.0 && !(d < opaque)) discard;
    if (u_layer > 0) {
        float front = texelFetch(u_front, px, 0).w;
        if (!(front > 0.0 && d > front)) discard;     // the same expression wrote front: the
    }                                                 // previous layer's fragment is peeled
    vec3 n = normalize(v_normal);
    if (dot(n, -v_view) < 0.0) n = -n;   // two-sided, as the G-buffer
    out_position = vec4(v_view, d);
    out_normal = vec4(n, v_material.x);
    out_albedo = vec4(v_albedo, v_material.y);
    out_opacity = vec4(v_opacity, 0.0, 0.0, 0.0);
}
