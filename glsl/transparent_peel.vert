#version 430
// Transparent layers (app/pipeline/transparent.py): the G-buffer's vertex stage, with the mesh's opacity.
uniform mat4 u_view_from_world;
uniform mat4 u_clip_from_view;
in vec3 in_position;
in vec3 in_normal;
in vec3 in_albedo;
in vec2 in_material;      // roughness (0: matte), metallic
in float in_opacity;
out vec3 v_view;
out vec3 v_normal;
out vec3 v_albedo;
flat out vec2 v_material;
flat out float v_opacity;

void main() {
    vec4 view = u_view_from_world * vec4(in_position, 1.0);
    v_view = view.xyz;
    v_normal = mat3(u_view_from_world) * in_normal;   // rigid view transform
    v_albedo = in_albedo;
    v_material = in_material;
    v_opacity = in_opacity;
    gl_Position = u_clip_from_view * view;
}
