"""The window's own GPU passes, declared like a technique's and run with Renderer.run over
the frame's buffers (the renderer binds what each declares; none is timed: they are the
window's cost, not the technique's):

    view_stats  present_stats.comp   out_color, out_stats, G-buffer depth (+ the reference's
                                     counters) -> view_stats (VIEW_STATS, 32 bytes) and
                                     view_extra (EXTRA_WORDS words): the HUD's frame sums,
                                     the heat scale, the exposure histogram, the diff count
    present     present.vert/.frag   out_color, out_stats, wave_stats -> a view, scaled to
                                     the target
    stash       present.vert/.frag   out_color, out_stats -> two textures (radiance, counters)
                                     that outlive the frame: the reference's (diff view) and
                                     the second technique's (split view)
    upscale     present.vert         a reduced frame's view, presented at its render size into
                upscale.frag         a texture (Upscale), over the window's viewport, bilinear

Textures: the G-buffer at units 0-2 (GBuffer.bind_textures); the stashes at the *_UNIT
units below (defines of present.frag, so each number is written here only).
"""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts

from .. import images
from ..pipeline.passes import OUT_COLOR, OUT_STATS, WAVE_STATS, Buffer, Draw, Pass
from ..views import VIEWS
from .views import view_defines

VIEW_STATS = "view_stats"
VIEW_EXTRA = "view_extra"
EXTRA_HEAD = ("lit", "max_exact", "reserved", "differ")      # then the histogram
STATS_BLOCK = 32                     # pixels a side of one view_stats group (present_stats.comp)
EXTRA_WORDS = len(EXTRA_HEAD) + images.HIST_BINS
UNITS = {"REF_COLOR_UNIT": 4, "REF_STATS_UNIT": 5, "SPLIT_COLOR_UNIT": 6, "SPLIT_STATS_UNIT": 7,
         "MAP_UNIT": 8}
FRAME_UNIT = 9                       # upscale.frag's (present.frag takes UNITS only)
FULL = (-1.0, -1.0, 1.0, 1.0)        # u_rect of a full-viewport quad (NDC x0, y0, x1, y1)


def present_defines() -> dict[str, object]:
    """present_common.glsl's constants, from app.images (their one definition)."""
    return {"HIST_BINS": images.HIST_BINS, "HIST_LOG2_MIN": float(images.HIST_LOG2_MIN),
            "HIST_LOG2_MAX": float(images.HIST_LOG2_MAX), "HEAT_ZERO": float(images.HEAT_ZERO),
            "HEAT_OVERLAY_ALPHA": float(images.HEAT_OVERLAY_ALPHA)}


def _quad(target, viewport, blend: bool = False) -> Draw:
    """Four vertices from gl_VertexID (present.vert) over the viewport."""
    return Draw(count=4, mode="triangle_strip", target=target, blend=blend,
                viewport=(0, 0, *viewport))


def view_stats_pass(size, reference: bool = False) -> Pass:
    """Frame sums over the pixels geometry covers (ViewStats + the extra words); with
    `reference`, pixels whose light set differs from the stashed reference's."""
    w, h = size
    return Pass("view_stats", "present_stats.comp", reads=(OUT_COLOR, OUT_STATS),
                writes={VIEW_STATS: Buffer(layouts.VIEW_STATS.itemsize, layouts.VIEW_STATS, cleared=True),
                        VIEW_EXTRA: Buffer(EXTRA_WORDS * 4, None, cleared=True)},
                groups=(-(-w // STATS_BLOCK), -(-h // STATS_BLOCK), 1), timed=False,
                defines=dict(present_defines(), REF=int(reference), REF_UNIT=UNITS["REF_STATS_UNIT"]),
                uniforms={"u_size": (w, h)})


def read_extra(words: np.ndarray) -> dict:
    """The view_extra words as {lit, max_exact, max_nodes, differ, hist}."""
    words = np.asarray(words, np.uint32)
    out = {k: int(words[i]) for i, k in enumerate(EXTRA_HEAD)}
    out["hist"] = words[len(EXTRA_HEAD):EXTRA_WORDS].astype(np.int64)
    return out


def present_pass(target, size, viewport, view: str, uniforms: dict) -> Pass:
    """One view of the frame, drawn into `target` (the window's framebuffer or a
    screenshot's) at `viewport` size; `uniforms`: present.frag's (exposure, heat scale,
    grid, split, inspect ...)."""
    u = {"u_rect": FULL, "u_size": tuple(size), "u_viewport": tuple(viewport),
         "u_view": VIEWS.index(view)}
    u.update(uniforms)
    return Pass("present", ("present.vert", "present.frag"),
                reads=(OUT_COLOR, OUT_STATS, WAVE_STATS), draw=_quad(target, viewport), timed=False,
                defines=dict(present_defines(), STASH=0, **view_defines(), **UNITS), uniforms=u)


def stash_pass(fbo, size) -> Pass:
    """This frame's radiance and counters into the textures of `fbo` (RGBA32F, RGBA32UI)."""
    return Pass("stash", ("present.vert", "present.frag"), reads=(OUT_COLOR, OUT_STATS),
                draw=_quad(fbo, size), timed=False,
                defines=dict(present_defines(), STASH=1, **view_defines(), **UNITS),
                uniforms={"u_rect": FULL, "u_size": tuple(size)})


def upscale_pass(target, viewport) -> Pass:
    """The view presented into Upscale's texture (bound at FRAME_UNIT), scaled to `viewport`
    of `target` with bilinear filtering."""
    return Pass("upscale", ("present.vert", "upscale.frag"), draw=_quad(target, viewport),
                timed=False, defines={"FRAME_UNIT": FRAME_UNIT}, uniforms={"u_rect": FULL})


class Upscale:
    """A reduced frame's view at its render size: an RGBA8 texture, filtered linearly."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.size = None
        self.fbo = self.color = None

    def ensure(self, size) -> None:
        if self.size == tuple(size):
            return
        self.release()
        import moderngl
        self.size = tuple(size)
        self.color = self.ctx.texture(self.size, 4)
        self.color.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.color.repeat_x = self.color.repeat_y = False
        self.fbo = self.ctx.framebuffer([self.color])

    def bind(self) -> None:
        self.color.use(FRAME_UNIT)

    def release(self) -> None:
        for o in (self.fbo, self.color):
            if o is not None:
                o.release()
        self.fbo = self.color = None
        self.size = None


class Stash:
    """Two textures a frame is copied into (stash_pass), kept across frames; `key` is the
    state it was rendered for (camera, lights, size, technique, options)."""

    def __init__(self, ctx, color_unit: int, stats_unit: int):
        self.ctx = ctx
        self.units = (color_unit, stats_unit)
        self.size = None
        self.key = None
        self.fbo = self.color = self.stats = None

    def ensure(self, size) -> None:
        if self.size == tuple(size):
            return
        self.release()
        self.size = tuple(size)
        import moderngl
        self.color = self.ctx.texture(self.size, 4, dtype="f4")
        self.stats = self.ctx.texture(self.size, 4, dtype="u4")
        for t in (self.color, self.stats):
            t.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.fbo = self.ctx.framebuffer([self.color, self.stats])
        self.key = None

    def bind(self) -> None:
        if self.color is not None:
            self.color.use(self.units[0])
            self.stats.use(self.units[1])

    def release(self) -> None:
        for o in (self.fbo, self.color, self.stats):
            if o is not None:
                o.release()
        self.fbo = self.color = self.stats = None
        self.size = self.key = None
