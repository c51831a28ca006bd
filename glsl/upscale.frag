#version 430
// The window's upscale pass (app/window/passes.py): a reduced frame's view, presented at its
// render size into a texture, drawn over the window's viewport with bilinear filtering
// (dynamic resolution while the camera moves: app/window/scale.py).
// define: FRAME_UNIT
layout(binding = FRAME_UNIT) uniform sampler2D u_frame;
in vec2 v_uv;
out vec4 frag;

void main() {
    frag = vec4(texture(u_frame, v_uv).rgb, 1.0);
}
