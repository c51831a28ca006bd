#version 430
// The window's present and stash passes (app/window/passes.py): one quad over u_rect (NDC
// x0, y0, x1, y1), drawn as a 4-vertex triangle strip with no vertex buffer.
uniform vec4 u_rect;
out vec2 v_uv;

void main() {
    vec2 corner = vec2(gl_VertexID & 1, (gl_VertexID >> 1) & 1);
    v_uv = corner;
    gl_Position = vec4(mix(u_rect.xy, u_rect.zw, corner), 0.0, 1.0);
}
