"""A technique the tests register and unregister (test_frame_graph, test_bench_sweep, the
window in its own process): a compute prepass marking every light, a raster pass covering the
frame from its fragments, and a shading pass reading both, so that a technique of three kinds
of pass goes through the frame graph, the bench and the window."""
from __future__ import annotations

from dataclasses import dataclass

from app.pipeline.passes import Buffer, Draw, Pass
from app.techniques.base import Technique, prepare, shading_pass
from app.techniques.options import TechniqueOptions, option

KEEP = """#version 430
// define: KEEP_VALUE
// Throw-away prepass: keep[i] = KEEP_VALUE for every visible light.
layout(local_size_x = 64) in;
layout(std430, binding = B_KEEP) writeonly buffer Keep { uint keep[]; };
uniform uint u_light_count;
void main() { if (gl_GlobalInvocationID.x < u_light_count) keep[gl_GlobalInvocationID.x] = KEEP_VALUE; }
"""
COVER_VERT = """#version 430
// A triangle over the whole viewport, from gl_VertexID alone.
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
COVER_FRAG = """#version 430
// Throw-away raster pass: every covered pixel marks itself.
layout(std430, binding = B_COVERED) writeonly buffer Covered { uint covered[]; };
uniform ivec2 u_size;
void main() { ivec2 p = ivec2(gl_FragCoord.xy); covered[p.y * u_size.x + p.x] = 1u; }
"""
SHADE = """#version 430
// define: KEEP_VALUE
#include "generated.glsl"
#include "wave.glsl"
#include "common.glsl"
layout(std430, binding = B_KEEP) readonly buffer Keep { uint keep[]; };
layout(std430, binding = B_COVERED) readonly buffer Covered { uint covered[]; };
void main() {
    PixelState s = load_pixel();
    if (s.shading && covered[s.pixel.y * u_size.x + s.pixel.x] == 1u)
        for (uint i = 0u; i < u_light_count; ++i)
            if (keep[i] == KEEP_VALUE) evaluate_light(s, lights[i]);
    store_pixel(s);
    write_wave_stats(s.evaluated, 1u);
}
"""


class Throwaway(Technique):
    name = "throwaway"
    summary = "test only: compute prepass + raster pass + shading pass"
    glsl = {"tw_keep.comp": KEEP, "tw_cover.vert": COVER_VERT, "tw_cover.frag": COVER_FRAG,
            "tw_shade.comp": SHADE}

    @dataclass(frozen=True)
    class Options(TechniqueOptions):
        keep_value: int = option(7, "the mark the prepass writes and the shading pass wants",
                                 lo=1, hi=1000)

    def build(self, frame, opts):
        return prepare(frame)

    def passes(self, build, opts):
        w, h = build.frame.size
        n = len(build.lights.gpu)
        defines = {"KEEP_VALUE": f"{opts.keep_value}u"}
        return [
            Pass("keep", "tw_keep.comp", writes={"keep": Buffer(max(n, 1) * 4)},
                 groups=(max(1, -(-n // 64)), 1, 1), defines=defines),
            Pass("cover", ("tw_cover.vert", "tw_cover.frag"),
                 writes={"covered": Buffer(w * h * 4, cleared=True)},
                 draw=Draw(count=3, target="none")),
            shading_pass(build, "tw_shade.comp", ("keep", "covered"), defines=defines),
        ]
