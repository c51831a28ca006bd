"""The window's own GPU passes, declared like a technique's and run with Renderer.run over
the frame's buffers (the renderer binds what each declares; none is timed: they are the
window's cost, not the technique's):

    view_stats  present_stats.comp   out_stats + G-buffer depth -> view_stats (VIEW_STATS,
                                     32 bytes: the HUD's frame sums and the heat scale)
    present     present.vert/.frag   out_color, out_stats, wave_stats, view_stats -> a view
    hud         present.vert/.frag   the HUD text texture (unit HUD_UNIT), blended, top left

Textures: the G-buffer position texture at unit 0 (GBuffer.bind_textures), the HUD text at
HUD_UNIT (a define of present.frag, so the number is written here only).
"""
from __future__ import annotations

from cpu_prep import layouts

from ..pipeline.passes import OUT_COLOR, OUT_STATS, WAVE_STATS, Buffer, Draw, Pass, image_groups
from .views import VIEWS, Overlay

VIEW_STATS = "view_stats"
HUD_UNIT = 3
FULL = (-1.0, -1.0, 1.0, 1.0)        # u_rect of a full-viewport quad (NDC x0, y0, x1, y1)


def _quad(target, size, blend: bool = False) -> Draw:
    """Four vertices from gl_VertexID (present.vert), over the whole render size."""
    return Draw(count=4, mode="triangle_strip", target=target, blend=blend,
                viewport=(0, 0, *size))


def view_stats_pass(size) -> Pass:
    """Frame sums over the pixels geometry covers (ViewStats)."""
    w, h = size
    return Pass("view_stats", "present_stats.comp", reads=(OUT_STATS,),
                writes={VIEW_STATS: Buffer(layouts.VIEW_STATS.itemsize, layouts.VIEW_STATS, cleared=True)},
                groups=image_groups(w, h), uniforms={"u_size": (w, h)}, timed=False)


def present_pass(target, size, view: str, overlay: Overlay, heat_max: float) -> Pass:
    """One view of the frame, drawn into `target` (the window's framebuffer or a
    screenshot's)."""
    return Pass("present", ("present.vert", "present.frag"),
                reads=(OUT_COLOR, OUT_STATS, WAVE_STATS, VIEW_STATS),
                draw=_quad(target, size), defines={"HUD": 0}, timed=False,
                uniforms={"u_rect": FULL, "u_size": tuple(size), "u_view": VIEWS.index(view),
                          "u_tile": overlay.tile, "u_slices": overlay.slices,
                          "u_slice_scale": overlay.slice_scale, "u_slice_bias": overlay.slice_bias,
                          "u_heat_max": float(heat_max)})


def hud_pass(target, size, hud_size) -> Pass:
    """The HUD texture (bound at HUD_UNIT) blended over the top-left corner, pixel for pixel."""
    w, h = size
    tw, th = hud_size
    rect = (-1.0, 1.0 - 2.0 * min(th, h) / h, -1.0 + 2.0 * min(tw, w) / w, 1.0)
    return Pass("hud", ("present.vert", "present.frag"), draw=_quad(target, size, blend=True),
                defines={"HUD": 1, "HUD_UNIT": HUD_UNIT}, uniforms={"u_rect": rect}, timed=False)
