"""The window itself: a moderngl-window WindowConfig that renders one frame of the current
technique per on_render through the renderer's public API, then draws the current view and
the HUD with its own passes (app.window.passes) over that frame's buffers.

    render(technique, readback=False) -> FrameResult: meta (CPU/GPU ms, stats, options)
                                         and build (the grid the overlays draw)
    run([view_stats]) -> read("view_stats")   32 bytes: the HUD's only readback
    run([present, hud]) into the window's framebuffer (or a screenshot's)
"""
from __future__ import annotations

import json
from pathlib import Path
import sys
import time

import moderngl_window as mglw
import numpy as np

from cpu_prep.camera import frame_camera

from ..pipeline import gl
from ..pipeline.renderer import Renderer
from ..techniques import REGISTRY
from . import passes
from .camera import FlyCamera
from .hud import HudTexture, hud_lines, title
from .keys import CHAR_KEYS, MOVE_KEYS, key_names
from .options import WindowOptions
from .views import VIEWS, Overlay, view_note

REPLAY_STEP_S = 0.25          # a replayed W/A/S/D/Q/E moves this many seconds' worth
HUD_REFRESH_S = 0.25          # interactive HUD/title refresh (scripted runs: every frame)


class LabWindow(mglw.WindowConfig):
    title = "many-light lab"
    gl_version = (4, 3)
    resizable = True
    clear_color = (0.0, 0.0, 0.0, 1.0)

    def __init__(self, setup: dict, **kwargs):
        """setup: args (the parsed command line), scene, technique (its name), given
        (the option flags given), builtin (the scene is a builtin one)."""
        super().__init__(**kwargs)
        a = self.args = setup["args"]
        self.scene = setup["scene"]
        self.options = WindowOptions(setup["given"])
        self.names = list(REGISTRY)
        self.tech_index = self.names.index(setup["technique"])
        self.view = VIEWS.index(a.view)
        self.builtin = setup["builtin"]
        self.light_sets = {len(self.scene.lights): self.scene.lights}
        self.lights = self.scene.lights
        gl.use_context(self.ctx)          # the window's context is the process's one context
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
        self.shots: list[str] = []
        self.message, self.message_until = "", 0.0
        self.log = a.json or a.frames is not None
        self.history: list[dict] = []
        self.figures: dict = {}
        self.overlay = Overlay()
        self.hud = HudTexture(self.ctx)
        self._hud_key = None
        self._hud_time = -1.0
        self._shot_fbo = None
        self.key_map = key_names(self.wnd.keys)
        if self.wnd.name != "headless":
            self.wnd.exit_key = None          # Esc is ours: it may take the screenshot first

    # ---- state -----------------------------------------------------------------------
    def _buffer_size(self):
        w, h = self.wnd.buffer_size
        return max(int(w), 1), max(int(h), 1)

    @property
    def technique(self):
        return REGISTRY[self.names[self.tech_index]]

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

    def _path_camera(self):
        return self.scene.camera_at(self.path_frame, self.args.path_frames)

    def _adopt_path_camera(self) -> None:
        if self.playing:
            self.playing = False
            self.cam.set_from(self._path_camera())

    def _move(self, axes, dt: float, fast: bool = False) -> None:
        d = self.speed * dt * (4.0 if fast else 1.0)
        self.cam.move(axes[0] * d, axes[1] * d, axes[2] * d)

    def press(self, name: str, replayed: bool = False) -> None:
        """One key press, by key name (app.window.keys.KEY_NAMES)."""
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

    # ---- moderngl-window events ------------------------------------------------------
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

    # ---- the frame -------------------------------------------------------------------
    def on_render(self, time_s, frame_time):
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
        r = self.renderer
        size = self._buffer_size()
        if size != r.size:
            r.resize(size)
        cam = self._path_camera() if self.playing else self.cam.camera()
        tech = self.technique
        opts, _ = self.options.for_technique(tech)
        result = r.render(tech, self.path_frame, opts, frames=self.args.path_frames,
                          lights=self.lights, readback=False, camera=frame_camera(cam, *size))
        self.overlay = Overlay.of(result.build.grid)
        self.figures = self._figures(result, self._view_stats(), cam)
        self._draw(self.wnd.fbo)
        if self.playing:
            self.path_frame += 1
        self.frame += 1
        self._record(key)
        if self.shot_pending:
            self.shot_pending = False
            name = (f"window-{self.scene.name}-{tech.name}-{VIEWS[self.view]}-"
                    f"{self.frame:05d}.png")
            self._write_screenshot(Path(self.args.shot_dir) / name)
        if self.args.frames is not None and self.frame >= self.args.frames:
            if self.args.screenshot:
                self._write_screenshot(self.args.screenshot)
            self.wnd.close()

    def _view_stats(self):
        """The frame sums (one ViewStats) over this frame's out_stats and G-buffer depth."""
        r = self.renderer
        r.gbuffer.bind_textures()
        r.run([passes.view_stats_pass(r.size)])
        return r.read(passes.VIEW_STATS)[0]

    def _figures(self, result, s, cam) -> dict:
        """The frame's figures: the HUD's, the title's and the JSON line's."""
        m = result.meta
        covered = int(s["covered"])
        total = lambda lo, hi: float(s[lo]) + float(s[hi]) * 2.0**32
        _, ignored = self.options.for_technique(self.technique)
        return {
            "technique": m["technique"], "view": VIEWS[self.view], "lights": int(len(self.lights)),
            "visible_lights": int(m["stats"].get("visible_lights", len(result.build.lights.gpu))),
            "evaluated_per_pixel": total("evaluated_lo", "evaluated_hi") / covered if covered else 0.0,
            "exact_per_pixel": total("exact_lo", "exact_hi") / covered if covered else 0.0,
            "max_evaluated": int(s["max_evaluated"]), "covered": covered,
            "cpu_ms": {k: round(float(v), 3) for k, v in m["cpu_ms"].items()},
            "gpu_ms": {k: round(float(v), 3) for k, v in m["gpu_ms"].items()},
            "setup_ms": {k: round(float(v), 3) for k, v in m["setup_ms"].items()},
            "options": m["options"], "ignored_options": list(ignored),
            "grid": self.overlay.as_dict(),
            "size": list(self.renderer.size), "playing": self.playing, "path_frame": self.path_frame,
            "camera": [round(float(v), 3) for v in cam.position],
            "target": [round(float(v), 3) for v in cam.target],
        }

    def _draw(self, target) -> None:
        """The current view, and the HUD over it, into `target` (a moderngl framebuffer)."""
        r = self.renderer
        self._update_hud_and_title()
        steps = [passes.present_pass(target, r.size, VIEWS[self.view], self.overlay,
                                     self.args.heat_max)]
        if self.hud_on and self.hud.texture is not None:
            self.hud.texture.use(passes.HUD_UNIT)
            steps.append(passes.hud_pass(target, r.size, self.hud.texture.size))
        r.gbuffer.bind_textures()
        r.run(steps)

    # ---- HUD, title, screenshots -----------------------------------------------------
    def _hud_lines(self) -> list[str]:
        f, tech = self.figures, self.technique
        top = self.args.heat_max or max(f["max_evaluated"], 1)
        message = self.message if self.message and time.perf_counter() < self.message_until else ""
        return hud_lines(f, position=f"{self.tech_index + 1}/{len(self.names)}", role=tech.role,
                         software=self.renderer.limits.software, playing=self.playing,
                         options=self.options.hud_line(tech),
                         note=view_note(f["view"], tech.name, self.overlay, top), message=message)

    def _update_hud_and_title(self) -> None:
        now = time.perf_counter()
        key = (self.tech_index, self.view, len(self.lights), self.hud_on, self.renderer.size, self.message)
        if not self.log and key == self._hud_key and now - self._hud_time < HUD_REFRESH_S:
            return
        self._hud_key, self._hud_time = key, now
        self.wnd.title = title(self.figures)
        if self.hud_on:
            self.hud.draw(self._hud_lines(), self.renderer.size)

    def _write_screenshot(self, path) -> None:
        """Draw the current frame again into an offscreen framebuffer and save it (the
        window's own back buffer is not readable on every window type)."""
        from PIL import Image
        size = self.renderer.size
        if self._shot_fbo is None or self._shot_fbo.size != size:
            if self._shot_fbo is not None:
                self._shot_fbo.release()
            self._shot_fbo = self.ctx.simple_framebuffer(size, components=4)
        self._draw(self._shot_fbo)
        w, h = size
        rgb = np.frombuffer(self._shot_fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(np.ascontiguousarray(rgb[::-1])).save(path)
        self.say(f"screenshot: {path}")
        self.shots.append(str(path))

    def _record(self, key) -> None:
        f = dict(self.figures, frame=self.frame - 1, key=key)
        self.history.append({k: f[k] for k in ("technique", "view", "lights", "size")})
        if self.log:
            f["evaluated_per_pixel"] = round(f["evaluated_per_pixel"], 4)
            f["exact_per_pixel"] = round(f["exact_per_pixel"], 4)
            print(json.dumps(f), flush=True)
