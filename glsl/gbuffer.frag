#version 430
// G-buffer: view-space position (w = linear depth; 0 where no geometry), normal (w =
// roughness, 0 = matte), albedo (a = metallic).  Every shading pass reads P from here, so all
// techniques test lights at the same P.
in vec3 v_view;
in vec3 v_normal;
in vec3 v_albedo;
flat in vec2 v_material;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_albedo;

void main() {
    vec3 n = normalize(v_normal);
    if (dot(n, -v_view) < 0.0) n = -n;   // two-sided: interiors are seen from inside
    out_position = vec4(v_view, -v_view.z);
    out_normal = vec4(n, v_material.x);
    out_albedo = vec4(v_albedo, v_material.y);
}
