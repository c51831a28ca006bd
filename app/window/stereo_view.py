"""Two eyes in the window (`--views stereo`, B toggles): every frame both eyes rendered by
app.stereo.render (per-view or union, the capture's ways) from the fly camera, each at half
the window's width, and shown side by side, left eye on the left.

    EyeRenderer     the renderer as app.stereo sees it here: its centre camera is the fly
                    camera's frame camera (at the eye's size), its lights the window's
    StereoComposer  the two-eye frame: after each eye's render (the renderer holds that
                    eye's buffers) the window's own passes take that eye's sums and present
                    its view into a texture of its own; draw() puts the two textures side by
                    side.  Both eyes show the left eye's exposure and heat scale (one colour
                    bar), unless the panel fixes them.  The figures: CPU and GPU ms of both
                    eyes summed (the union way's shared stage once), per-pixel figures over
                    both eyes' pixels, and each eye's own (the HUD's stereo lines)

The views of an eye's own buffers are shown (views.STEREO_VIEWS); diff, split, maps,
variants and inspect need a second frame or the mono frame's structure: mono only.  A fog
scene is rendered per view only, as capture refuses the union way there; at rest (nothing
it was rendered from, nor the panel, changed) its two-eye frame is held as a mono one is.
"""
from __future__ import annotations

from dataclasses import replace
import time

from .. import images, stereo
from ..errors import UserError
from . import passes
from .compose import Composed
from .figures import frame_sums, heat_top
from .views import Overlay, present_view

FOG_UNION = ("--stereo-way union: a fog scene's froxels take their candidates from cells in the "
             "eye's own camera, which the union's shared structure does not index; --stereo-way "
             "per-view renders it")
LEFT_RECT, RIGHT_RECT = (-1.0, -1.0, 0.0, 1.0), (0.0, -1.0, 1.0, 1.0)


def eye_size(size) -> tuple[int, int]:
    """One eye's pixels in a window of `size`: half its width."""
    return max(1, int(size[0]) // 2), max(1, int(size[1]))


def refusal(scene, technique, opts, way: str) -> str | None:
    """Why the window cannot show `technique` in stereo `way` (one line), else None."""
    if scene.fog is not None and way == "union":
        return FOG_UNION
    return stereo.refusal(technique, technique.resolve_options(opts), way)


class EyeRenderer:
    """The window's renderer with the fly camera as the centre camera and the window's lights."""

    def __init__(self, renderer):
        self.renderer = renderer
        self.center = None
        self.lights = None

    def __getattr__(self, name):
        return getattr(self.renderer, name)

    def camera(self, frame, frames):
        return self.center

    def frame_input(self, frame, frames, lights=None, camera=None):
        return self.renderer.frame_input(frame, frames, self.lights if lights is None else lights, camera)

    def render(self, technique, frame=0, opts=None, frames=64, **kw):
        kw.setdefault("lights", self.lights)
        return self.renderer.render(technique, frame, opts, frames, **kw)


class StereoComposer:
    def __init__(self, ctx, composer, way: str, separation: float):
        self.composer = composer
        self.way = way
        self.separation = stereo.check_separation(separation)
        self.proxy = EyeRenderer(composer.renderer)
        self.eyes = {e: passes.Upscale(ctx) for e in stereo.EYES}
        self._held = None                   # (what it rendered, Composed, figures, frame)

    def render(self, plan, state, frame, scene, key=None):
        """Both eyes of `frame` ((lights, centre frame camera, eye size, path frame, path
        frames, window frame)): (Composed of the two-eye frame, the stereo figures).  A fog
        scene at rest (the composer's hold, `key` and the state as they were): the last
        two-eye frame again, its eyes' views as they were presented."""
        lights, fc, size, path_frame, frames = frame[:5]
        c = self.composer
        what = (plan.technique.name, tuple(sorted(plan.opts.as_dict().items())), key, tuple(size),
                state.version, self.way, self.separation)
        if c.hold and key is not None and self._held is not None and self._held[0] == what:
            c._held, c.held_since = None, self._held[3]
            return self._held[1], self._held[2]
        c.invalidate()                      # the renderer's buffers are the eyes' from here
        self._held = None
        why = refusal(scene, plan.technique, plan.opts, self.way)
        if why:
            raise UserError(why)
        self.proxy.center, self.proxy.lights = fc, lights
        eyes, scale = {}, {}

        def on_eye(eye, result):
            stats, extra = c._view_stats(False)
            sums = frame_sums(stats, extra)
            if "exposure" not in scale:     # the left eye's exposure and heat scale for both
                scale["exposure"] = (images.exposure_from_histogram(extra["hist"])
                                     if state.exposure_auto else state.exposure_manual)
                scale["heat"] = heat_top(state, sums, None)
            comp = Composed(result, sums, extra, scale["exposure"], False, None, None,
                            Overlay.of(result.build.grid), 0.0)
            c.upload_scene_view(state.view, result, size, scale.get("map"))
            scale.setdefault("map", c.map_shown[2])
            c.present(comp, state, fc, size, scale["heat"], size[0] + 1)
            self._present_eye(eye, size, state.view)
            eyes[eye] = comp

        t0 = time.perf_counter()
        sf = stereo.render(self.proxy, plan.technique, plan.opts, self.way, self.separation,
                           path_frame, frames, readback=False, on_eye=on_eye)
        render_ms = (time.perf_counter() - t0) * 1e3
        state.exposure_now = scale["exposure"]
        left, right = (eyes[e] for e in stereo.EYES)
        out = self._both(sf, left, right, render_ms), self._figures(sf, eyes, size)
        if c.hold:
            self._held = (what, *out, frame[5] if len(frame) > 5 else 0)
        return out

    def _present_eye(self, eye, size, view) -> None:
        c = self.composer
        r = c.renderer
        up = self.eyes[eye]
        up.ensure(size)
        r.gbuffer.bind_textures()
        if c._map_tex is not None:
            c._map_tex.use(passes.UNITS["MAP_UNIT"])
        r.run([passes.present_pass(up.fbo, size, size, present_view(view), c.uniforms)])

    @staticmethod
    def _both(sf, left, right, render_ms) -> Composed:
        """The two-eye frame as one Composed: its ms summed (StereoFrame.samples), its sums
        over both eyes' pixels."""
        a, b = left.sums, right.sums
        cov = a["covered"] + b["covered"]
        per = lambda k: (a[k] * a["covered"] + b[k] * b["covered"]) / cov if cov else 0.0
        sums = {"evaluated_per_pixel": per("evaluated_per_pixel"), "exact_per_pixel": per("exact_per_pixel"),
                "max_evaluated": max(a["max_evaluated"], b["max_evaluated"]),
                "max_exact": max(a["max_exact"], b["max_exact"]), "covered": cov}
        extra = dict(left.extra, lit=left.extra["lit"] + right.extra["lit"],
                     max_exact=max(left.extra["max_exact"], right.extra["max_exact"]))
        sample = sf.samples()[0]
        meta = dict(left.result.meta, cpu_ms=sample["cpu_ms"], gpu_ms=sample["gpu_ms"])
        t = [e.result.meta.get("transparent") for e in (left, right)]
        if t[0]:
            gpu = {}
            for m in t:
                for k, v in m["gpu_ms"].items():
                    gpu[k] = gpu.get(k, 0.0) + v
            meta["transparent"] = dict(t[0], gpu_ms=gpu)
        return Composed(replace(left.result, meta=meta), sums, extra, left.exposure, False, None,
                        None, left.overlay, render_ms)

    def _figures(self, sf, eyes, size) -> dict:
        out = {"way": sf.way, "separation": sf.separation, "share": sf.share, "eye_size": list(size),
               "shared_cpu_ms": ({k: round(v, 3) for k, v in sf.shared_ms[-1].items()}
                                 if sf.shared_ms else None), "eyes": {}}
        for e, comp in eyes.items():
            m = comp.result.meta
            out["eyes"][e] = {
                "visible_lights": int(m["stats"].get("visible_lights", len(comp.result.build.lights.gpu))),
                "evaluated_per_pixel": round(comp.sums["evaluated_per_pixel"], 4),
                "exact_per_pixel": round(comp.sums["exact_per_pixel"], 4),
                "cpu_ms": round(sum(m["cpu_ms"].values()), 3),
                "gpu_ms": round(sum(m["gpu_ms"].values()), 3)}
        return out

    def draw(self, target, viewport) -> None:
        """The two eyes' views side by side over `viewport` of `target`."""
        r = self.composer.renderer
        for eye, rect in zip(stereo.EYES, (LEFT_RECT, RIGHT_RECT)):
            up = self.eyes[eye]
            if up.fbo is None:
                continue
            up.bind()
            r.run([replace(passes.upscale_pass(target, viewport), uniforms={"u_rect": rect})])

    def release(self) -> None:
        for up in self.eyes.values():
            up.release()
