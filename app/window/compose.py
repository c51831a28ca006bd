"""The frame composer: renders what the current view needs through the renderer's public
API, then draws the view with the window's own passes (app.window.passes).

    render(technique, readback=False) -> FrameResult: meta (CPU/GPU ms, stats, options)
                                         and build (the grid the overlays draw)
    run([view_stats]) -> read(view_stats, view_extra)   the HUD's sums, the heat scale, the
                                                        exposure histogram, the diff count
    run([present])  into the window's framebuffer (or a screenshot's)

Other frames a view needs are rendered first and stashed into textures (passes.Stash):

    split   the second technique, every frame the split view is on
    diff    the reference (brute), only while the diff view is on and only when the camera,
            lights or size changed since its last frame; in an interactive session it waits
            until they have been still for REF_SETTLE_S (flying is not held up by the
            reference's seconds-long frames), in a scripted run it renders at once.  Until
            then the view says the reference is pending.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import time

import moderngl
import numpy as np

from .. import images
from ..techniques import REGISTRY
from . import passes
from .figures import frame_sums, split_figures
from .inspect import Inspection, inspect
from . import variant_view
from ..views import HEAT_OF, PASS_VIEWS, VIEWS
from .fog_view import FROXEL_VIEW, LAYERS_VIEW, FroxelView, layers_map, layers_note
from .views import Overlay, present_view

REF_SETTLE_S = 0.3            # interactive: the reference renders once the view is this still


@dataclass
class Plan:
    """What a frame renders: the technique, the split view's second one, the reference."""
    technique: object
    opts: object
    split: tuple | None           # (technique, opts)
    reference: tuple | None       # (technique, opts) when the reference renders this frame

    def renders(self) -> list[tuple]:
        return [(self.technique, self.opts)] + [p for p in (self.split, self.reference) if p]


@dataclass
class Composed:
    """One composed frame: the technique's result and what the figures read of it."""
    result: object
    sums: dict                    # figures.frame_sums
    extra: dict                   # passes.read_extra
    exposure: float
    ref_valid: bool               # the stashed reference is this frame's (the diff view)
    split: dict | None            # figures.split_figures of the second technique
    inspection: Inspection | None
    overlay: Overlay
    render_ms: float


class FrameComposer:
    def __init__(self, ctx, renderer, reference):
        self.ctx = ctx
        self.renderer = renderer
        self.reference = reference
        self.ref_stash = passes.Stash(ctx, passes.UNITS["REF_COLOR_UNIT"], passes.UNITS["REF_STATS_UNIT"])
        self.split_stash = passes.Stash(ctx, passes.UNITS["SPLIT_COLOR_UNIT"], passes.UNITS["SPLIT_STATS_UNIT"])
        self.map_index = 0                # the maps view: which of the technique's maps
        self.map_shown = ("", "", 0.0)    # its name, label and heat-scale top
        self._map_tex = None
        self._upscale = passes.Upscale(ctx)   # a reduced frame's view, before it is scaled up
        self._variants = None             # the variants view: the frame's stats, when it has them
        self.view_shown = "shaded"
        self.uniforms: dict = {}
        self._still = (None, time.perf_counter())     # the view's key, and since when
        self.froxels = FroxelView()       # the froxels view's slice (fog scenes)
        self.layers_note = ""             # the layers view's HUD line (transparent surfaces)
        self.hold = False                 # a fog scene: hold a frame while nothing moved
        self._held = None                 # (what it rendered, FrameResult, frame) of the last render
        self.held_since = None            # the frame number a held frame was rendered at

    def invalidate(self) -> None:
        """Other frames rendered since the last one (stereo's eyes): none is held."""
        self._held, self.held_since = None, None

    def still_s(self, key) -> float:
        """How long the view (camera, lights, size: `key`) has been as it is now."""
        if key != self._still[0]:
            self._still = (key, time.perf_counter())
        return time.perf_counter() - self._still[1]

    # ---- rendering ---------------------------------------------------------------------------
    def plan(self, state, key, settled: bool) -> Plan:
        """settled: the view has been still long enough for the reference (or a scripted run)."""
        tech = state.tech
        split = REGISTRY.get(state.split_with) if state.view == "split" else None
        want_ref = state.view == "diff" and self.ref_stash.key != key and settled
        return Plan(tech, state.options.for_technique(tech)[0],
                    (split, state.options.for_technique(split)[0]) if split is not None else None,
                    (self.reference, self.reference.Options()) if want_ref else None)

    def render(self, plan: Plan, state, frame, key, debug_pixel) -> Composed:
        """frame: (lights, frame camera, size, path frame, path frames); debug_pixel: the
        cursor's pixel (GL coordinates) when inspecting."""
        lights, fc, size, path_frame, frames = frame[:5]
        frame_no = frame[5] if len(frame) > 5 else 0
        r = self.renderer
        run = lambda t, opts, **kw: r.render(t, path_frame, opts, frames=frames, lights=lights,
                                             readback=False, camera=fc, **kw)
        if plan.reference is not None:
            self._stash(self.ref_stash, run(*plan.reference), size)
            self.ref_stash.key = key
        split = None
        if plan.split is not None:
            res = run(*plan.split)
            self._stash(self.split_stash, res, size)
            split = split_figures(plan.split[0], res.meta, *self._view_stats(False))
        t0 = time.perf_counter()
        # a fog scene at rest: the last frame again when nothing it was rendered from changed
        # and nothing rendered since (its buffers are still the renderer's), so that its
        # froxel sets are not rebuilt on the CPU every frame
        what = (plan.technique.name, tuple(sorted(plan.opts.as_dict().items())), key, tuple(size))
        fresh = plan.reference is not None or plan.split is not None or debug_pixel is not None
        if self.hold and not fresh and self._held is not None and self._held[0] == what:
            result, self.held_since = self._held[1], self._held[2]
        else:
            result = run(plan.technique, plan.opts, debug_pixel=None if debug_pixel is None else
                         (debug_pixel[0], size[1] - 1 - debug_pixel[1]))
            self._held, self.held_since = ((what, result, frame_no) if self.hold and not fresh
                                           else None), None
        ref_valid = state.view == "diff" and self.ref_stash.key == key
        stats, extra = self._view_stats(ref_valid)
        render_ms = (time.perf_counter() - t0) * 1e3
        if state.view == "maps":
            self._upload_map(plan.technique, result, size)
        if state.view == "variants":
            self._upload_variants(result)
        self.upload_scene_view(state.view, result, size)
        exposure = images.exposure_from_histogram(extra["hist"]) if state.exposure_auto else state.exposure_manual
        state.exposure_now = exposure
        ins = self._inspect(result, debug_pixel, size) if debug_pixel is not None else None
        return Composed(result, frame_sums(stats, extra), extra, exposure, ref_valid, split, ins,
                        Overlay.of(result.build.grid), render_ms)

    def _stash(self, stash, result, size) -> None:
        """The frame just rendered, its radiance and counters, into a stash's textures."""
        stash.ensure(size)
        self.renderer.gbuffer.bind_textures()
        self.renderer.run([passes.stash_pass(stash.fbo, size)])

    def _view_stats(self, reference: bool):
        """The frame sums (one ViewStats) and the extra words (view_extra) of this frame."""
        r = self.renderer
        r.gbuffer.bind_textures()
        if reference:
            self.ref_stash.bind()
        r.run([passes.view_stats_pass(r.size, reference)])
        return r.read(passes.VIEW_STATS)[0], passes.read_extra(r.read(passes.VIEW_EXTRA))

    def _inspect(self, result, pixel, size) -> Inspection:
        r = self.renderer
        w, h = size
        x, y = pixel
        grid = result.build.grid
        if grid is not None:
            g = int(grid.tile)
            rect = (x // g * g, y // g * g, min(x // g * g + g, w), min(y // g * g + g, h))
        else:
            rect = (x, y, x + 1, y + 1)
        x0, y0, x1, y1 = rect
        raw = r.gbuffer.fbo.read(viewport=(x0, y0, x1 - x0, y1 - y0), components=4, attachment=0, dtype="f4")
        positions = np.frombuffer(raw, np.float32).reshape(y1 - y0, x1 - x0, 4)
        st = np.frombuffer(r.output("out_stats").read(size=16, offset=(y * w + x) * 16), np.uint32)
        ids = result.debug_lights if result.debug_lights is not None else []
        return inspect(pixel, result.build, ids, int(st[0]), positions, rect)

    def _upload_map(self, tech, result, size) -> None:
        """The maps view: the technique's map number map_index (Technique.maps, read from this
        frame), each cell over the pixels it covers, into a float texture at MAP_UNIT; one
        heat scale over all of this technique's maps, so that they compare."""
        maps = tech.maps(result, self.renderer.read)
        if not maps:
            self.map_shown = ("", "", 0.0)
            return
        names = list(maps)
        name = names[self.map_index % len(names)]
        values, label = maps[name]
        full = images.cells_to_pixels(np.asarray(values, np.float32), size)[::-1]     # GL rows
        self._write_map(full, size)
        self.map_shown = (name, label, images.maps_top(maps))

    def _write_map(self, pixels, size) -> None:
        """A per-pixel count (GL rows) into the map texture at MAP_UNIT."""
        if self._map_tex is None or self._map_tex.size != size:
            if self._map_tex is not None:
                self._map_tex.release()
            self._map_tex = self.ctx.texture(size, 1, dtype="f4")
            self._map_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._map_tex.write(np.ascontiguousarray(pixels, np.float32).tobytes())

    def upload_scene_view(self, view, result, size, top: float | None = None) -> None:
        """The froxels view (slice k's froxel light counts, fog_view.FroxelView) or the
        layers view (lights evaluated over the opaque surface and its layers) as the map;
        `top`: its scale's top instead of its own (stereo's right eye: the left's)."""
        fixed = top
        if view == FROXEL_VIEW:
            pixels, top, label = self.froxels.map_of(self.renderer, self.renderer.scene, result, size)
        elif view == LAYERS_VIEW:
            pixels, top, label, used = layers_map(self.renderer)
            self.layers_note = layers_note(top, used)
        else:
            return
        self._write_map(pixels, size)
        self.map_shown = (view, label, top if fixed is None else fixed)

    def _upload_variants(self, result) -> None:
        """The variants view: each variant tile's colour (VARIANT_VIEW) from this frame's
        tile masks, the HUD's note and the panel's legend; none when the frame ran no variants."""
        stats = result.meta["stats"]
        self.map_shown = ("variants", variant_view.legend_note(stats), 0.0)
        self._variants = None
        if "variant_masks" in stats and "tile_masks" in self.renderer.provided():
            colors = variant_view.tile_colors(stats, self.renderer.read("tile_masks"))
            self.renderer.upload(variant_view.VARIANT_VIEW, colors)
            self._variants = stats

    def variant_legend(self) -> list:
        """The variants view's legend (variant_view.legend) while it is shown, else []."""
        if self.view_shown != "variants" or self._variants is None:
            return []
        return variant_view.legend(self._variants)

    # ---- drawing -------------------------------------------------------------------------------
    def present(self, c: Composed, state, fc, size, heat_max: float, split_x: int) -> None:
        """The present pass's uniforms for the view now shown."""
        o, ins = c.overlay, c.inspection
        tile = ins.tile if ins is not None and ins.tile is not None else (-1, -1, -1, -1)
        self.view_shown = state.view
        self.uniforms = {
            "u_exposure": float(c.exposure), "u_ambient": float(state.ambient),
            "u_heat_max": float(heat_max),
            "u_heat_of": HEAT_OF.index(state.heat_of), "u_heat_overlay": int(state.heat_overlay),
            "u_tile": o.tile, "u_slices": o.slices, "u_slice_scale": o.slice_scale,
            "u_slice_bias": o.slice_bias, "u_ref_valid": int(c.ref_valid),
            "u_split_x": split_x if c.split is not None else size[0] + 1,
            "u_split_view": VIEWS.index(state.split_view),
            "u_cursor_tile": tuple(int(v) for v in tile),
            "u_cursor": tuple(ins.pixel) if ins is not None else (-1, -1),
            "u_light_sphere": tuple(ins.sphere) if ins is not None and ins.sphere else (0.0, 0.0, 0.0, 0.0),
            "u_tan_half": (float(fc.tan_half_x), float(fc.tan_half_y)),
            "u_map_max": float(self.map_shown[2] or 1.0)}

    def draw(self, target, viewport) -> None:
        """The view now shown into `target` (a moderngl framebuffer); a frame rendered at
        another size than `viewport` (dynamic resolution) is presented at its own size and
        scaled up bilinearly (a software rasterizer pays the present pass per pixel)."""
        r = self.renderer
        r.gbuffer.bind_textures()
        self.ref_stash.bind()
        self.split_stash.bind()
        if self._map_tex is not None:
            self._map_tex.use(passes.UNITS["MAP_UNIT"])
        reduced = tuple(r.size) != tuple(viewport)
        into, at = target, viewport
        if reduced:
            self._upscale.ensure(r.size)
            into, at = self._upscale.fbo, r.size
        own = self.view_shown in PASS_VIEWS      # drawn over the shaded view by a pass of its own
        steps = [passes.present_pass(into, r.size, at, "shaded" if own else present_view(self.view_shown),
                                     self.uniforms)]
        if self.view_shown == "variants" and self._variants is not None:
            steps.append(variant_view.overlay_pass(into, r.size, at, self._variants))
        r.run(steps)
        if reduced:
            self._upscale.bind()
            r.run([passes.upscale_pass(target, viewport)])


class Screenshots:
    """The frame drawn again into an offscreen framebuffer and saved as a PNG (the window's
    own back buffer is not readable on every window type)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.pending = False                      # K / F12: after this frame
        self.paths: list[str] = []
        self.huds: list[list[str]] = []           # the HUD text each screenshot carries
        self._fbo = None

    def take(self, size, draw, path) -> Path:
        """draw(framebuffer) draws the frame and its UI and returns the UIModel it drew."""
        from PIL import Image
        if self._fbo is None or self._fbo.size != size:
            if self._fbo is not None:
                self._fbo.release()
            self._fbo = self.ctx.simple_framebuffer(size, components=4)
        self._fbo.use()
        self._fbo.clear(0.0, 0.0, 0.0, 1.0)
        model = draw(self._fbo)
        self.huds.append(model.hud_lines if model.hud else [])
        w, h = size
        rgb = np.frombuffer(self._fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(np.ascontiguousarray(rgb[::-1])).save(path)
        self.paths.append(str(path))
        return path
