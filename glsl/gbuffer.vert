#version 430
uniform mat4 u_view_from_world;
uniform mat4 u_clip_from_view;
in vec3 in_position;
in vec3 in_normal;
in vec3 in_albedo;
in vec2 in_material;      // roughness (0: matte), metallic
out vec3 v_view;
out vec3 v_normal;
out vec3 v_albedo;
flat out vec2 v_material;

void main() {
    vec4 view = u_view_from_world * vec4(in_position, 1.0);
    v_view = view.xyz;
    v_normal = mat3(u_view_from_world) * in_normal;   // rigid view transform
    v_albedo = in_albedo;
    v_material = in_material;
    gl_Position = u_clip_from_view * view;
}
