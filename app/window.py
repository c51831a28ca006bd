"""Live window: the capture pipeline, every frame, in a moderngl-window app.

    python -m app.window [--scene city] [--technique hybrid] [--view shaded] [--lights N]
                         [--size WxH] [--window pyglet|glfw|headless] [--backend egl]
                         [--frames N] [--screenshot PATH] [--keys "3,v,v"] [technique options]

Keys: 1..9 technique (REGISTRY order), V next view (shaded, heat, classes, tiles, slices),
W/A/S/D fly (Q/E down/up, Shift faster, scroll wheel changes speed), drag the mouse to look,
P play/stop the scene's camera path, R reset the camera, + / - (or ] / [) double / halve the
light count, K or F12 screenshot, H hide the HUD, Esc quit.

The views are drawn by one fullscreen pass (glsl/present.frag) that reads the renderer's
storage buffers directly; the only per-frame readback is 32 bytes of frame sums
(glsl/present_stats.comp) for the HUD.  Scripted runs: --frames N exits after N frames and
prints one JSON line per frame and a summary line; --keys replays key names, one per frame,
from the first frame; --screenshot writes the last frame (at --frames N, or on Esc).
`--window headless` renders to an EGL framebuffer with no display (backend egl by default).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from . import cli
from .errors import UserError

VIEWS = ("shaded", "heat", "classes", "tiles", "slices")
MOVE_KEYS = {"w": (1, 0, 0), "s": (-1, 0, 0), "d": (0, 1, 0), "a": (0, -1, 0),
             "e": (0, 0, 1), "q": (0, 0, -1)}
# Key names of --keys (and of the handler): what a key press means, window-independent.
KEY_NAMES = tuple("123456789") + tuple(MOVE_KEYS) + ("v", "p", "r", "h", "k", "f12", "+", "-",
                                                     "]", "[", "escape")
CHAR_KEYS = {"+": "+", "=": "+", "-": "-", "_": "-", "]": "+", "[": "-"}
REPLAY_STEP_S = 0.25          # a replayed W/A/S/D/Q/E moves this many seconds' worth
HUD_REFRESH_S = 0.25          # interactive HUD/title refresh (scripted runs: every frame)


# ---- arguments -----------------------------------------------------------------------

def parse_keys(text: str) -> list[str]:
    keys = [k.strip().lower() for k in text.split(",") if k.strip()]
    bad = [k for k in keys if k not in KEY_NAMES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown key(s) {', '.join(bad)} (known: {' '.join(KEY_NAMES)})")
    return keys


def _positive(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got '{text}'") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def build_parser():
    import moderngl_window as mglw
    # moderngl-window's own flags (--window, --backend, --fullscreen, --vsync, --resizable,
    # --hidden, --samples, --cursor, --size_mult); our --size (WxH) replaces its --size.
    p = cli.Parser(prog="python -m app.window", description=__doc__.splitlines()[0],
                   parents=[mglw.create_parser()], conflict_handler="resolve")
    cli.add_scene_args(p)
    p.add_argument("--technique", default=None, help="starting technique id (default: the first)")
    p.add_argument("--view", choices=VIEWS, default="shaded", help="starting view")
    p.add_argument("--frames", type=_positive, help="exit after N frames (scripted run)")
    p.add_argument("--screenshot", help="PNG of the last frame")
    p.add_argument("--keys", type=parse_keys, default=[], help='key names replayed one per frame, e.g. "3,v,v"')
    p.add_argument("--path", action="store_true", help="start playing the camera path")
    p.add_argument("--path-frames", type=_positive, default=600,
                   help="frames of one camera-path loop (capture --frame K --frames F = path frame K of F)")
    p.add_argument("--heat-max", type=float, default=0.0,
                   help="heat view: lights per pixel at the top of the ramp (0: the frame's max)")
    p.add_argument("--no-hud", action="store_true", help="start with the HUD hidden")
    p.add_argument("--json", action="store_true", help="print a JSON line per frame (default with --frames)")
    p.add_argument("--shot-dir", default=".", help="folder of K/F12 screenshots")
    cli.add_option_args(p)
    return p


def key_names(keys) -> dict:
    """{window key code: key name} for a moderngl-window Keys class; +, -, [ and ] come as
    characters (on_unicode_char_entered), so keyboard layouts do not matter for them."""
    pairs = [(getattr(keys, f"NUMBER_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, f"NUMPAD_{i}", None), str(i)) for i in range(1, 10)]
    pairs += [(getattr(keys, c.upper(), None), c) for c in "wasdqevprhk"]
    pairs += [(getattr(keys, "F12", None), "f12"), (getattr(keys, "ESCAPE", None), "escape")]
    return {code: name for code, name in pairs if code not in (None, "undefined")}


# ---- camera ----------------------------------------------------------------------------

class FlyCamera:
    """Position + yaw/pitch around the scene camera's up axis (PyGLM)."""

    def __init__(self, cam):
        from pyglm import glm
        self.glm = glm
        self.base = cam
        self.set_from(cam)

    def set_from(self, cam) -> None:
        glm = self.glm
        self.source = cam           # returned as is until the camera moves (frame 0 = capture's)
        self.up = glm.normalize(glm.vec3(*cam.up))
        self.pos = glm.vec3(*cam.position)
        f = glm.normalize(glm.vec3(*cam.target) - self.pos)
        # frame: yaw about up, pitch towards up
        self.pitch = math.asin(max(-1.0, min(1.0, glm.dot(f, self.up))))
        ref = self._reference()
        side = glm.normalize(glm.cross(ref, self.up))
        flat = f - self.up * glm.dot(f, self.up)
        self.yaw = math.atan2(glm.dot(flat, side), glm.dot(flat, ref)) if glm.length(flat) > 1e-9 else 0.0

    def _reference(self):
        glm = self.glm
        ref = glm.vec3(0, 0, -1) if abs(self.up.z) < 0.9 else glm.vec3(1, 0, 0)
        return glm.normalize(ref - self.up * glm.dot(ref, self.up))

    def forward(self):
        glm = self.glm
        ref = self._reference()
        side = glm.normalize(glm.cross(ref, self.up))
        flat = ref * math.cos(self.yaw) + side * math.sin(self.yaw)
        return glm.normalize(flat * math.cos(self.pitch) + self.up * math.sin(self.pitch))

    def move(self, fwd: float, right: float, up: float) -> None:
        glm = self.glm
        f = self.forward()
        r = glm.normalize(glm.cross(f, self.up))
        self.pos += f * fwd + r * right + self.up * up
        self.source = None

    def turn(self, dyaw: float, dpitch: float) -> None:
        self.yaw += dyaw
        self.pitch = max(-1.55, min(1.55, self.pitch + dpitch))
        self.source = None

    def camera(self):
        from scenes.model import Camera
        if self.source is not None:
            return self.source
        b = self.base
        t = self.pos + self.forward()
        return Camera(tuple(map(float, self.pos)), tuple(map(float, t)), tuple(map(float, self.up)),
                      b.fov_y_deg, b.near, b.far)


class _Recording:
    """Delegates to a technique and keeps its last Build, so that the HUD has the CPU stage
    figures and the grid without a readback (Renderer.render returns None then)."""

    def __init__(self, technique):
        self._technique = technique
        self.last = None

    def __getattr__(self, name):
        return getattr(self._technique, name)

    def build(self, frame, opts):
        self.last = self._technique.build(frame, opts)
        return self.last


# ---- the window ------------------------------------------------------------------------

def _window_config_class():
    import moderngl
    import moderngl_window as mglw

    class LabWindow(mglw.WindowConfig):
        title = "many-light lab"
        gl_version = (4, 3)
        resizable = True
        clear_color = (0.0, 0.0, 0.0, 1.0)

        def __init__(self, setup: dict, **kwargs):
            super().__init__(**kwargs)
            from cpu_prep.grid import make_grid
            from . import features as feat, gl
            from .renderer import Renderer
            from .techniques import REGISTRY
            self.make_grid = make_grid
            self.feat = feat
            a = self.args = setup["args"]
            self.scene = setup["scene"]
            self.opts = setup["opts"]
            self.names = list(REGISTRY)
            self.registry = REGISTRY
            self.tech_index = self.names.index(setup["technique"])
            self.view = VIEWS.index(a.view)
            self.light_sets = {len(self.scene.lights): self.scene.lights}
            self.lights = self.scene.lights
            self.builtin = setup["builtin"]
            gl.use_context(self.ctx)
            self.limits = gl.limits()
            self.renderer = Renderer(self.scene, self._buffer_size())
            self.cam = FlyCamera(self.scene.camera)
            extent = float(self.scene.max_depth or self.scene.camera.far)
            self.speed = max(extent / 40.0, 1.0)          # m/s
            self.playing = bool(a.path)
            self.path_frame = 0
            self.held: set[str] = set()
            self.replay = list(a.keys)
            self.hud_on = not a.no_hud
            self.frame = 0
            self.shot_pending = False
            self.message, self.message_until = "", 0.0
            self.log = a.json or a.frames is not None
            self.history: list[dict] = []
            self.figures: dict = {}
            self._hud_key = None
            self._hud_time = -1.0
            self._hud_tex = None
            self._shot_fbo = None
            # programs
            virtual = {"generated.glsl": feat.generated_glsl()}
            self.b_view = feat.BINDINGS["view_stats"]
            programs = self.renderer.programs
            self.present = programs.program("present.vert", "present.frag", {"HUD": 0}, virtual)
            self.hud_prog = programs.program("present.vert", "present.frag", {"HUD": 1}, virtual)
            self.present_vao = self.ctx.vertex_array(self.present, [])
            self.hud_vao = self.ctx.vertex_array(self.hud_prog, [])
            self.stats_prog = self.renderer.programs.compute(
                "present_stats.comp", {}, virtual)
            self.view_stats = self.ctx.buffer(reserve=32)
            self.font_cache: dict = {}
            self.key_map = key_names(self.wnd.keys)
            if self.wnd.name != "headless":
                self.wnd.exit_key = None          # Esc is ours: it may take the screenshot first

        # ---- helpers ---------------------------------------------------------------
        def _buffer_size(self):
            w, h = self.wnd.buffer_size
            return max(int(w), 1), max(int(h), 1)

        @property
        def technique(self):
            return self.registry[self.names[self.tech_index]]

        def say(self, text: str, seconds: float = 3.0) -> None:
            self.message, self.message_until = text, time.perf_counter() + seconds
            print(text, file=sys.stderr, flush=True)

        def _set_light_count(self, n: int) -> None:
            from scenes import load_scene
            from scenes.loader import MAX_LIGHTS
            n = max(0, min(int(n), MAX_LIGHTS))
            if not self.builtin:
                total = len(self.scene.lights)
                if n > total:
                    self.say(f"the scene file has {total} lights")
                    n = total
                self.lights = self.scene.lights[:n]
                return
            if n not in self.light_sets:
                a = self.args
                self.light_sets[n] = load_scene(a.scene, lights=n, seed=a.seed,
                                                distribution=a.distribution).lights
            self.lights = self.light_sets[n]

        def _adopt_path_camera(self) -> None:
            if self.playing:
                self.playing = False
                self.cam.set_from(self._path_camera())

        def _path_camera(self):
            return self.scene.camera_at(self.path_frame, self.args.path_frames)

        def press(self, name: str, replayed: bool = False) -> None:
            """One key press, by key name (KEY_NAMES)."""
            if name.isdigit():
                i = int(name) - 1
                if i < len(self.names):
                    self.tech_index = i
                else:
                    self.say(f"no technique {name}: {len(self.names)} registered")
            elif name == "v":
                self.view = (self.view + 1) % len(VIEWS)
            elif name == "p":
                if self.playing:
                    self._adopt_path_camera()
                else:
                    self.playing = True
            elif name == "r":
                self.playing = False
                self.path_frame = 0
                self.cam.set_from(self.scene.camera)
            elif name == "h":
                self.hud_on = not self.hud_on
            elif name in ("k", "f12"):
                self.shot_pending = True
            elif name in ("+", "]"):
                self._set_light_count(max(1, len(self.lights) * 2))
            elif name in ("-", "["):
                self._set_light_count(len(self.lights) // 2)
            elif name == "escape":
                if self.args.screenshot and self.frame:
                    self._write_screenshot(self.args.screenshot)
                self.wnd.close()
            elif name in MOVE_KEYS and replayed:
                self._adopt_path_camera()
                self._move(MOVE_KEYS[name], REPLAY_STEP_S)
            self._hud_key = None        # state changed: refresh the HUD now

        def _move(self, axes, dt: float, fast: bool = False) -> None:
            d = self.speed * dt * (4.0 if fast else 1.0)
            self.cam.move(axes[0] * d, axes[1] * d, axes[2] * d)

        # ---- moderngl-window events -------------------------------------------------
        def on_key_event(self, key, action, modifiers):
            name = self.key_map.get(key)
            if name is None:
                return
            if action == self.wnd.keys.ACTION_PRESS:
                if name in MOVE_KEYS:
                    self.held.add(name)
                    self._adopt_path_camera()
                else:
                    self.press(name)
            elif action == self.wnd.keys.ACTION_RELEASE:
                self.held.discard(name)

        def on_unicode_char_entered(self, char):
            if char in CHAR_KEYS:
                self.press(CHAR_KEYS[char])

        def on_mouse_drag_event(self, x, y, dx, dy):
            self._adopt_path_camera()
            self.cam.turn(dx * 0.004, -dy * 0.004)

        def on_mouse_scroll_event(self, x_offset, y_offset):
            self.speed *= 1.25 ** y_offset
            self.say(f"fly speed {self.speed:.1f} m/s", 1.5)

        def on_resize(self, width, height):
            self._hud_key = None    # the renderer follows wnd.buffer_size in on_render

        # ---- the frame ---------------------------------------------------------------
        def on_render(self, time_s, frame_time):
            from cpu_prep.camera import frame_camera
            key = None
            if self.replay:
                key = self.replay.pop(0)
                self.press(key, replayed=True)
                if self.wnd.is_closing:
                    return
            dt = min(max(frame_time, 0.0), 0.1)
            fast = bool(getattr(self.wnd.modifiers, "shift", False))
            for k in self.held:
                self._move(MOVE_KEYS[k], dt, fast)
            size = self._buffer_size()
            if size != self.renderer.size:
                self.renderer.resize(size)
            w, h = size
            cam = self._path_camera() if self.playing else self.cam.camera()
            fc = frame_camera(cam, w, h)
            tech = _Recording(self.technique)
            timer = self.renderer.timer
            take, gpu = timer.take, {}
            timer.take = lambda: gpu.update(take()) or dict(gpu)
            try:
                self.renderer.render(tech, self.path_frame, self.opts, frames=self.args.path_frames,
                                     lights=self.lights, readback=False, camera=fc)
            finally:
                del timer.take
            self._frame_stats(tech.last, gpu, fc)
            self.figures["camera"] = [round(float(v), 3) for v in cam.position]
            self.figures["target"] = [round(float(v), 3) for v in cam.target]
            self._draw(self.wnd.fbo, size)
            if self.playing:
                self.path_frame += 1
            self.frame += 1
            self._record(key)
            if self.shot_pending:
                self.shot_pending = False
                a = self.args
                name = f"window-{self.scene.name}-{self.technique.name}-{VIEWS[self.view]}-{self.frame:05d}.png"
                self._write_screenshot(Path(a.shot_dir) / name)
            if self.args.frames is not None and self.frame >= self.args.frames:
                if self.args.screenshot:
                    self._write_screenshot(self.args.screenshot)
                self.wnd.close()

        def _frame_stats(self, build, gpu_ms: dict, fc) -> None:
            """Figures for the HUD: the renderer's meta when it keeps one, else the Build."""
            ctx, r = self.ctx, self.renderer
            w, h = r.size
            ctx.memory_barrier()        # the shade pass's storage writes before our reads
            self.view_stats.clear()
            r.gbuffer.position.use(0)
            r.buffers["out_stats"].bind_to_storage_buffer(self.feat.BINDINGS["out_stats"])
            self.view_stats.bind_to_storage_buffer(self.b_view)
            self.stats_prog["u_size"].value = (w, h)
            self.stats_prog.run(math.ceil(w / 8), math.ceil(h / 8), 1)
            ctx.memory_barrier()
            s = np.frombuffer(self.view_stats.read(), np.uint32).astype(np.float64)
            covered = s[0]
            meta = getattr(r, "last_meta", None)
            cpu = dict(meta["cpu_ms"]) if meta else dict(build.times.ms)
            gpu = dict(meta["gpu_ms"]) if meta else gpu_ms
            visible = (meta or {}).get("stats", build.stats).get("visible_lights", len(build.lights.gpu))
            self.build, self.fc = build, fc
            self.figures = {
                "technique": self.technique.name, "view": VIEWS[self.view], "lights": int(len(self.lights)),
                "visible_lights": int(visible),
                "evaluated_per_pixel": float((s[1] + s[2] * 2.0**32) / covered) if covered else 0.0,
                "exact_per_pixel": float((s[4] + s[5] * 2.0**32) / covered) if covered else 0.0,
                "max_evaluated": int(s[3]), "covered": int(covered),
                "cpu_ms": {k: round(float(v), 3) for k, v in cpu.items()},
                "gpu_ms": {k: round(float(v), 3) for k, v in gpu.items()},
                "size": [w, h], "playing": self.playing, "path_frame": self.path_frame,
            }

        def _grid(self):
            """Grid of the view overlays: the technique's own, else one from the options."""
            b = getattr(self, "build", None)
            g = b.grid if b is not None else None
            if g is not None and g.slices > 1:
                return g, g.tile
            o, cam = self.opts, self.fc
            slices = self.make_grid(cam, o.tile, o.slices, self.scene.max_depth or cam.far, o.near_slice_depth)
            return slices, (g.tile if g is not None else o.tile)

        def _draw(self, fbo, size) -> None:
            ctx, r = self.ctx, self.renderer
            w, h = size
            fbo.use()
            ctx.viewport = (0, 0, w, h)
            ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
            r.gbuffer.position.use(0)
            for n in ("out_color", "out_stats", "wave_stats"):
                r.buffers[n].bind_to_storage_buffer(self.feat.BINDINGS[n])
            self.view_stats.bind_to_storage_buffer(self.b_view)
            grid, tile = self._grid()
            p = self.present
            uniforms = {"u_rect": (-1.0, -1.0, 1.0, 1.0), "u_size": (w, h), "u_view": self.view,
                        "u_tile": int(tile), "u_slices": grid.slices,
                        "u_slice_scale": float(grid.slice_scale), "u_slice_bias": float(grid.slice_bias),
                        "u_heat_max": float(self.args.heat_max)}
            for k, v in uniforms.items():
                if k in p:
                    p[k].value = v
            self.present_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
            self._update_hud_and_title()
            if self.hud_on and self._hud_tex is not None:
                tw, th = self._hud_tex.size
                x1, y1 = -1.0 + 2.0 * min(tw, w) / w, 1.0 - 2.0 * min(th, h) / h
                self._hud_tex.use(3)
                self.hud_prog["u_rect"].value = (-1.0, y1, x1, 1.0)
                ctx.enable(moderngl.BLEND)
                ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
                self.hud_vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
                ctx.disable(moderngl.BLEND)

        # ---- HUD, title, screenshots -----------------------------------------------
        def _hud_lines(self) -> list[str]:
            f = self.figures
            cpu, gpu = f["cpu_ms"], f["gpu_ms"]
            wall = " (wall clock: software GL)" if self.limits.software else ""
            lines = [
                f"{f['technique']} ({self.tech_index + 1}/{len(self.names)})   view: {f['view']}   "
                f"{f['size'][0]}x{f['size'][1]}" + ("   path" if self.playing else ""),
                f"lights {f['lights']}   visible {f['visible_lights']}   "
                f"evaluated/px {f['evaluated_per_pixel']:.2f}   exact/px {f['exact_per_pixel']:.2f}",
                f"CPU {sum(cpu.values()):.1f} ms: " + "  ".join(f"{k} {v:.1f}" for k, v in cpu.items()),
                f"GPU {sum(gpu.values()):.1f} ms{wall}: " + "  ".join(f"{k} {v:.1f}" for k, v in gpu.items()),
            ]
            if f["view"] == "heat":
                top = self.args.heat_max or max(f["max_evaluated"], 1)
                lines.append(f"heat: lights evaluated per pixel, 0 .. {top:g}, log turbo ramp")
            elif f["view"] == "classes":
                lines.append("8x8 waves: blue list, green tree, white mixed, grey empty")
            elif f["view"] == "slices":
                g, _ = self._grid()
                lines.append(f"depth slices: {g.slices} (listing 4), slice 0 grey = near slice")
            elif f["view"] == "tiles":
                lines.append(f"tiles: {self._grid()[1]} px")
            lines.append("1-9 technique  V view  WASD/QE+drag fly  P path  R reset  +/- lights  K shot  H hud")
            if self.message and time.perf_counter() < self.message_until:
                lines.append(self.message)
            return lines

        def _update_hud_and_title(self) -> None:
            now = time.perf_counter()
            key = (self.tech_index, self.view, len(self.lights), self.hud_on, self.renderer.size, self.message)
            if not self.log and key == self._hud_key and now - self._hud_time < HUD_REFRESH_S:
                return
            self._hud_key, self._hud_time = key, now
            f = self.figures
            self.wnd.title = (f"many-light lab: {f['technique']} | {f['view']} | {f['visible_lights']}/"
                              f"{f['lights']} lights | {f['evaluated_per_pixel']:.2f} eval/px | "
                              f"CPU {sum(f['cpu_ms'].values()):.1f} ms | GPU {sum(f['gpu_ms'].values()):.1f} ms")
            if self.hud_on:
                self._render_hud_texture(self._hud_lines())

        def _render_hud_texture(self, lines) -> None:
            from PIL import Image, ImageDraw, ImageFont
            w, h = self.renderer.size
            px = max(9, min(16, h // 30))
            font = self.font_cache.get(px)
            if font is None:
                try:
                    font = ImageFont.load_default(size=px)
                except TypeError:      # Pillow < 10.1: bitmap font only
                    font = ImageFont.load_default()
                self.font_cache[px] = font
            line_h = px + 3
            fit = max(1, (h - 4) // line_h)
            lines = lines[:fit]
            tw = min(w, 8 + max(int(math.ceil(font.getlength(l))) for l in lines))
            th = min(h, 6 + line_h * len(lines))
            img = Image.new("RGBA", (tw, th), (0, 0, 0, 150))
            d = ImageDraw.Draw(img)
            for i, line in enumerate(lines):
                d.text((4, 3 + i * line_h), line, font=font, fill=(255, 255, 255, 255))
            if self._hud_tex is None or self._hud_tex.size != (tw, th):
                if self._hud_tex is not None:
                    self._hud_tex.release()
                self._hud_tex = self.ctx.texture((tw, th), 4)
                self._hud_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._hud_tex.write(img.tobytes())

        def _write_screenshot(self, path) -> None:
            """Draw the current frame again into an offscreen framebuffer and save it (the
            window's own back buffer is not readable on every window type)."""
            from PIL import Image
            size = self.renderer.size
            if self._shot_fbo is None or self._shot_fbo.size != size:
                if self._shot_fbo is not None:
                    self._shot_fbo.release()
                self._shot_fbo = self.ctx.simple_framebuffer(size, components=4)
            self._draw(self._shot_fbo, size)
            w, h = size
            rgb = np.frombuffer(self._shot_fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.ascontiguousarray(rgb[::-1])).save(path)
            self.say(f"screenshot: {path}")
            self.shots = getattr(self, "shots", []) + [str(path)]

        def _record(self, key) -> None:
            f = dict(self.figures, frame=self.frame - 1, key=key)
            self.history.append({k: f[k] for k in ("technique", "view", "lights", "size")})
            if self.log:
                f["evaluated_per_pixel"] = round(f["evaluated_per_pixel"], 4)
                f["exact_per_pixel"] = round(f["exact_per_pixel"], 4)
                print(json.dumps(f), flush=True)

    return LabWindow


# ---- entry point -----------------------------------------------------------------------

def _open_window(args, size):
    import moderngl_window as mglw
    name = os.environ.get("MODERNGL_WINDOW") or args.window or "pyglet"
    backend = args.backend or ("egl" if name == "headless" else None)
    no_display = ("; there is no display: use --window headless, or run under xvfb-run -a"
                  if name != "headless" and not os.environ.get("DISPLAY")
                  and not os.environ.get("WAYLAND_DISPLAY") else "")
    try:
        cls = mglw.get_local_window_cls(name)
    except Exception as exc:
        raise UserError(f"window type '{name}' is not available "
                        f"({' '.join(str(exc).split())[:120]}){no_display}") from None
    w, h = int(size[0] * args.size_mult), int(size[1] * args.size_mult)
    try:
        window = cls(title="many-light lab", size=(w, h), fullscreen=bool(args.fullscreen),
                     resizable=True if args.resizable is None else args.resizable,
                     visible=not args.hidden, gl_version=(4, 3),
                     vsync=True if args.vsync is None else args.vsync,
                     samples=args.samples or 0, cursor=True if args.cursor is None else args.cursor,
                     backend=backend)
    except Exception as exc:
        raise UserError(f"could not open a {name} window with OpenGL 4.3 "
                        f"({' '.join(str(exc).split())[:160]}){no_display}") from None
    if window.ctx.version_code < 430:
        raise UserError(f"the {name} window's context is OpenGL {window.ctx.version_code}, 430 needed")
    mglw.activate_context(window=window)
    return window, name


def main(argv=None) -> None:
    args = build_parser().parse_args(argv)
    from scenes import BUILTIN_SCENES
    from .techniques import REGISTRY, get
    technique = get(args.technique).name if args.technique else next(iter(REGISTRY))
    if not (args.heat_max >= 0 and math.isfinite(args.heat_max)):
        raise UserError(f"--heat-max must be >= 0 (got {args.heat_max})")
    opts = cli.options_from(args)
    scene = cli.load_scene_args(args)
    size = args.size or tuple(scene.resolution)

    import weakref
    import moderngl_window as mglw
    from moderngl_window.timers.clock import Timer
    window, name = _open_window(args, size)
    cls = _window_config_class()
    setup = {"args": args, "scene": scene, "opts": opts, "technique": technique,
             "builtin": args.scene in BUILTIN_SCENES}
    app = cls(setup, ctx=window.ctx, wnd=window, timer=Timer())
    window._config = weakref.ref(app)
    window.swap_buffers()
    window.set_default_viewport()
    t0 = time.perf_counter()
    mglw.run_window_config_instance(app)
    # the states the run went through: [first frame, technique, view, lights, [w, h]] per change
    sequence = []
    for i, h in enumerate(app.history):
        state = [h["technique"], h["view"], h["lights"], h["size"]]
        if not sequence or sequence[-1][1:] != state:
            sequence.append([i] + state)
    print(json.dumps({"exit": "ok", "window": name, "frames": app.frame,
                      "wall_s": round(time.perf_counter() - t0, 2), "sequence": sequence,
                      "size": list(app.renderer.size),
                      "screenshots": getattr(app, "shots", []),
                      "renderer": app.limits.renderer}), flush=True)


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
