"""The window itself: a moderngl-window WindowConfig that renders one frame of the current
technique per on_render through the renderer's public API, then draws the current view and
the UI (app.window.ui) over that frame's buffers with its own passes (app.window.passes).

    render(technique, readback=False) -> FrameResult: meta (CPU/GPU ms, stats, options)
                                         and build (the grid the overlays draw)
    run([view_stats]) -> read(view_stats, view_extra)   the HUD's sums, the heat scale, the
                                                        exposure histogram, the diff count
    run([present]) + imgui into the window's framebuffer (or a screenshot's)

Other frames a view needs are rendered first and stashed into textures (passes.Stash):

    split   the second technique, every frame the split view is on
    diff    the reference (brute), only while the diff view is on and only when the camera,
            lights or size changed since its last frame; in an interactive session it waits
            until they have been still for REF_SETTLE_S (flying is not held up by the
            reference's seconds-long frames), in a scripted run it renders at once.  Until
            then the view says the reference is pending.

A frame predicted to take more than probe.SLOW_MS is announced in the HUD (a frame with the
warning is shown) before it starts.
"""
from __future__ import annotations

import json
from pathlib import Path
import sys
import time

import moderngl_window as mglw
import numpy as np

from cpu_prep.camera import frame_camera

from .. import images
from ..errors import UserError
from ..pipeline import gl
from ..pipeline.renderer import Renderer
from ..techniques import REGISTRY, with_role
from . import campath, passes, probe
from .camera import FlyCamera
from .hud import HELP, exposure_text, hud_lines, title
from .inspect import Inspection, inspect
from .keys import CHAR_KEYS, MOVE_KEYS, key_names
from .options import WindowOptions
from .panel import LabState, Panel
from .model import FrameModel
from .timers import Timers
from .ui import LabUI
from .views import HEAT_OF, VIEWS, Overlay, view_note

REPLAY_STEP_S = 0.25          # a replayed W/A/S/D/Q/E moves this many seconds' worth
REF_SETTLE_S = 0.3            # interactive: the reference renders once the view is this still
MESSAGE_S = 3.0


class LabWindow(mglw.WindowConfig):
    title = "many-light lab"
    gl_version = (4, 3)
    resizable = True
    clear_color = (0.0, 0.0, 0.0, 1.0)

    def __init__(self, setup: dict, **kwargs):
        """setup: args (the parsed command line), scene, technique (its name, or None: the
        fastest of `candidates`), candidates, given (the option flags given), builtin (the
        scene is a builtin one)."""
        super().__init__(**kwargs)
        a = self.args = setup["args"]
        self.scene = setup["scene"]
        gl.use_context(self.ctx)          # the window's context is the process's one context
        self.renderer = Renderer(self.scene, self._buffer_size())
        self.names = list(REGISTRY)
        self.reference = with_role("reference")
        n = len(self.scene.lights)
        self.state = LabState(REGISTRY, technique=setup["technique"] or setup["candidates"][0],
                              options=WindowOptions(setup["given"]), lights=n, view=a.view, seed=a.seed,
                              distribution=a.distribution, builtin=setup["builtin"], file_lights=n,
                              heat_max=a.heat_max, ambient=a.ambient, hud=not a.no_hud,
                              inspect=a.cursor is not None)
        if a.exposure != "auto":
            self.state.exposure_auto, self.state.exposure_ev = False, float(np.log2(float(a.exposure)))
        self.panel = Panel(self.state, actions={
            "play": ("play / stop the path (P)", self.toggle_play),
            "record": ("record / stop and save (C)", self.toggle_record),
            "reset_camera": ("reset the camera (R)", self.reset_camera),
            "screenshot": ("screenshot (K)", self.request_screenshot)})
        self.light_sets = {(n, a.seed, a.distribution): self.scene.lights}
        self.cam = FlyCamera(self.scene.camera)
        extent = float(self.scene.max_depth or self.scene.camera.far)
        self.speed = max(extent / 40.0, 1.0)          # m/s
        self.path = campath.load(a.replay) if a.replay else None
        self.playing = bool(a.path or self.path)
        self.path_frame = 0
        self.record_to = Path(a.record) if a.record else None
        self.recording: campath.CameraPath | None = None
        self.record_t0 = 0.0
        self.saved_paths: list[str] = []
        self.held: set[str] = set()
        self.replay = list(a.keys)
        self.frame = 0
        self.frame_dt = 1 / 60
        self.shot_pending = False
        self.shots: list[str] = []
        self.shot_huds: list[list[str]] = []          # the HUD text each screenshot carries
        self.message, self.message_until = "", 0.0
        self.warning = ""
        self.log = a.json or a.frames is not None
        self.scripted = a.frames is not None or bool(a.keys)
        self.history: list[dict] = []
        self.figures: dict = {}
        self.overlay = Overlay()
        self.timers = Timers()
        self.model = FrameModel()
        self.costs = probe.FrameCosts()
        self.announced: set = set()
        self.seen: set = set()
        self.ref_stash = passes.Stash(self.ctx, passes.UNITS["REF_COLOR_UNIT"], passes.UNITS["REF_STATS_UNIT"])
        self.split_stash = passes.Stash(self.ctx, passes.UNITS["SPLIT_COLOR_UNIT"], passes.UNITS["SPLIT_STATS_UNIT"])
        self.frame_key, self.key_since = None, time.perf_counter()
        self.mouse = self._parse_cursor(a.cursor)
        self.inspection: Inspection | None = None
        self.map_index = 0                # the maps view: which of the technique's maps
        self.map_shown = ("", "", 0.0)    # its name, label and heat-scale top
        self._map_tex = None
        self.uniforms: dict = {}
        self.view_shown = self.state.view
        self._shot_fbo = None
        self.ui = LabUI(self.wnd)
        self.key_map = key_names(self.wnd.keys)
        if self.wnd.name != "headless":
            self.wnd.exit_key = None          # Esc is ours: it may take the screenshot first
        self.started = ""
        if setup["technique"] is None:
            self._start_fastest(setup["candidates"])
        self.state.split_with = self.state.default_split()
        if self.state.view not in self.state.views():
            raise UserError(f"--view {self.state.view}: {self.state.technique} has no such view")
        self.state.version = 0
        if self.record_to is not None:
            self.toggle_record()

    # ---- start-up -------------------------------------------------------------------------
    def _start_fastest(self, candidates) -> None:
        """The fastest of the candidates on this scene and machine (probe.fastest), or the
        one the last probe chose for the same scene (and file), lights, size, renderer,
        techniques and code version."""
        if len(candidates) == 1:
            self.state.technique = candidates[0]
            self.started = f"{candidates[0]}: the only technique that takes the given options"
            return
        a = self.args
        key = probe.start_key(a, len(self.scene.lights), self.renderer.size,
                              self.renderer.limits.renderer, candidates, self.state.options.given)
        got = None if a.reprobe else probe.remembered(key)
        if got and got.get("technique") in candidates:
            name, times, size = got["technique"], got.get("times", {}), tuple(got.get("size", self.renderer.size))
            how = f"at the last probe, {got.get('when', '?')}; --reprobe measures again"
        else:
            t0 = time.perf_counter()
            lights = self._lights()
            name, times, size, skipped = probe.fastest(
                self.renderer, [REGISTRY[n] for n in candidates],
                lambda t: self.state.options.for_technique(t)[0], lights, self.scene.camera)
            if name is None:
                raise UserError("no technique can render this scene here (every one refused the probe frame)")
            how = f"probe at {size[0]}x{size[1]}, {time.perf_counter() - t0:.1f} s"
            if skipped:
                how += f"; not probed for time: {', '.join(skipped)}"
            else:
                probe.remember(key, {"technique": name, "times": times, "size": list(size),
                                     "when": time.strftime("%Y-%m-%d %H:%M")})
        self.state.technique = name
        for k, ms in times.items():
            self.costs.record(k, ms, size[0] * size[1], len(self.scene.lights))
        ranked = ", ".join(f"{k} {v:.0f} ms" for k, v in sorted(times.items(), key=lambda kv: kv[1]))
        self.started = f"started on {name}, the fastest exact technique here ({ranked}; {how})"
        print(f"window: {self.started}", file=sys.stderr, flush=True)

    @staticmethod
    def _parse_cursor(text):
        if not text:
            return None
        x, y = (int(v) for v in text.lower().split("x"))
        return (x, y)

    # ---- state -----------------------------------------------------------------------------
    def _buffer_size(self):
        w, h = self.wnd.buffer_size
        return max(int(w), 1), max(int(h), 1)

    @property
    def technique(self):
        return self.state.tech

    def say(self, text: str, seconds: float = MESSAGE_S) -> None:
        self.message, self.message_until = text, time.perf_counter() + seconds
        print(text, file=sys.stderr, flush=True)

    def _lights_key(self):
        s = self.state
        return (s.lights, s.seed, s.distribution) if s.builtin else (s.lights,)

    def _lights(self) -> np.ndarray:
        s = self.state
        if not s.builtin:
            return self.scene.lights[:s.lights]
        key = self._lights_key()
        if key not in self.light_sets:
            from scenes import load_scene
            self.light_sets[key] = load_scene(self.args.scene, lights=s.lights, seed=s.seed,
                                              distribution=s.distribution).lights
            if len(self.light_sets) > 8:           # a few sets kept: +/- back and forth is quick
                self.light_sets.pop(next(iter(self.light_sets)))
        return self.light_sets[key]

    def _path_camera(self):
        if self.path is not None:
            return self.path.camera(self.path_frame)
        return self.scene.camera_at(self.path_frame, self.args.path_frames)

    def _adopt_path_camera(self) -> None:
        if self.playing:
            self.playing = False
            self.cam.set_from(self._path_camera())

    def _move(self, axes, dt: float, fast: bool = False) -> None:
        d = self.speed * dt * (4.0 if fast else 1.0)
        self.cam.move(axes[0] * d, axes[1] * d, axes[2] * d)

    # ---- actions (keys and panel buttons) ----------------------------------------------------
    def toggle_play(self) -> None:
        if self.playing:
            self._adopt_path_camera()
        else:
            self.playing = True

    def reset_camera(self) -> None:
        self.playing = False
        self.path_frame = 0
        self.cam.set_from(self.scene.camera)

    def request_screenshot(self) -> None:
        self.shot_pending = True

    def toggle_record(self) -> None:
        if self.recording is None:
            self.recording = campath.CameraPath(scene=self.scene.name, size=self.renderer.size)
            self.record_t0 = time.perf_counter()
            self.say(f"recording the camera path (C stops and saves"
                     + (f" to {self.record_to})" if self.record_to else ")"))
        else:
            self._save_recording()

    def _save_recording(self) -> None:
        rec, self.recording = self.recording, None
        if rec is None or not len(rec):
            return
        path = self.record_to or Path(self.args.shot_dir) / f"path-{self.scene.name}-{time.strftime('%Y%m%d-%H%M%S')}.json"
        rec.save(path)
        self.saved_paths.append(str(path))
        self.say(f"camera path: {len(rec)} keys -> {path} (replay: --replay {path})")

    def press(self, name: str, replayed: bool = False) -> None:
        """One key press, by key name (app.window.keys.KEY_NAMES)."""
        s = self.state
        try:
            if name.isdigit():
                i = int(name) - 1
                if i < len(self.names):
                    s.set_technique(self.names[i])
                else:
                    self.say(f"no technique {name}: {len(self.names)} registered")
            elif name == "v":
                s.next_view()
            elif name == "o":
                s.heat_overlay = not s.heat_overlay
                if s.view != "heat" and "heat" in s.views():
                    s.view = "heat"
                s.changed()
            elif name == "i":
                s.inspect = not s.inspect
                s.changed()
            elif name == "m":
                if "maps" in s.views():
                    self.map_index += s.view == "maps"     # the first M shows the first map
                    s.view = "maps"
                    s.changed()
                else:
                    self.say(f"{s.technique} has no maps of its own")
            elif name == "p":
                self.toggle_play()
            elif name == "c":
                self.toggle_record()
            elif name == "r":
                self.reset_camera()
            elif name == "h":
                s.hud = not s.hud
                s.changed()
            elif name == "f1":
                s.panel = not s.panel
                s.changed()
            elif name in ("k", "f12"):
                self.request_screenshot()
            elif name in ("+", "]"):
                s.set_lights(min(max(1, s.lights * 2), s.max_lights if s.builtin else s.file_lights))
            elif name in ("-", "["):
                s.set_lights(s.lights // 2)
            elif name == "escape":
                if self.args.screenshot and self.frame:
                    self._write_screenshot(self.args.screenshot)
                self.wnd.close()
            elif name in MOVE_KEYS and replayed:
                self._adopt_path_camera()
                self._move(MOVE_KEYS[name], REPLAY_STEP_S)
        except UserError as exc:
            self.say(str(exc))

    def _apply(self, key: str, value) -> None:
        """A panel change (a widget's, or a scripted one): Panel.apply, errors shown."""
        try:
            self.panel.apply(key, value)
        except UserError as exc:
            self.say(str(exc))

    def _script_step(self, step: str) -> None:
        if "=" in step:
            key, _, value = step.partition("=")
            self.ui.queued.append((key, value))            # as a widget would: next frame
        elif step.startswith("click:"):
            key = step.split(":", 1)[1]
            if not (self.state.hud and self.state.panel) or not self.ui.click(key):
                self.say(f"click:{key}: that control is not on screen (panel hidden, section "
                         f"closed, or not a control of {self.state.technique})")
        else:
            self.press(step, replayed=True)

    # ---- moderngl-window events ----------------------------------------------------------------
    def on_key_event(self, key, action, modifiers):
        self.ui.forward("key_event", key, action, modifiers)
        name = self.key_map.get(key)
        if name is None or (self.ui.want_keyboard and name != "escape"):
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
        self.ui.forward("unicode_char_entered", char)
        if char in CHAR_KEYS and not self.ui.want_keyboard:
            self.press(CHAR_KEYS[char])

    def on_mouse_position_event(self, x, y, dx, dy):
        self.ui.forward("mouse_position_event", x, y, dx, dy)
        self.mouse = (x, y)

    def on_mouse_drag_event(self, x, y, dx, dy):
        self.ui.forward("mouse_drag_event", x, y, dx, dy)
        self.mouse = (x, y)
        if self.ui.want_mouse:
            return
        self._adopt_path_camera()
        self.cam.turn(dx * 0.004, -dy * 0.004)

    def on_mouse_press_event(self, x, y, button):
        self.ui.forward("mouse_press_event", x, y, button)

    def on_mouse_release_event(self, x, y, button):
        self.ui.forward("mouse_release_event", x, y, button)

    def on_mouse_scroll_event(self, x_offset, y_offset):
        self.ui.forward("mouse_scroll_event", x_offset, y_offset)
        if self.ui.want_mouse:
            return
        self.speed *= 1.25 ** y_offset
        self.say(f"fly speed {self.speed:.1f} m/s", 1.5)

    def on_resize(self, width, height):
        self.ui.forward("resize", width, height)   # the renderer follows wnd.buffer_size in on_render

    # ---- the frame -------------------------------------------------------------------------------
    def on_render(self, time_s, frame_time):
        t_start = time.perf_counter()
        self.frame_dt = frame_time
        for key, value in self.ui.take_queued():          # last frame's panel changes
            self._apply(key, value)
        step = self.replay.pop(0) if self.replay else None
        if step is not None:
            self._script_step(step)
            if self.wnd.is_closing:
                return
        for m in self.state.messages:
            self.say(m)
        self.state.messages.clear()
        dt = min(max(frame_time, 0.0), 0.1)
        fast = bool(getattr(self.wnd.modifiers, "shift", False))
        for k in self.held:
            self._move(MOVE_KEYS[k], dt, fast)
        r = self.renderer
        size = self._buffer_size()
        if size != r.size:
            r.resize(size)
        cam = self._path_camera() if self.playing else self.cam.camera()
        if self.recording is not None:
            self.recording.add(cam, time.perf_counter() - self.record_t0)
        s = self.state
        tech = s.tech
        opts, _ = s.options.for_technique(tech)
        lights = self._lights()
        fc = frame_camera(cam, *size)
        key = (tuple(cam.position), tuple(cam.target), tuple(cam.up), cam.fov_y_deg,
               self._lights_key(), size)
        if key != self.frame_key:
            self.frame_key, self.key_since = key, time.perf_counter()

        # announce slow frames, then render what the view needs besides the technique
        plan = [(tech, opts)]
        split = REGISTRY.get(s.split_with) if s.view == "split" else None
        if split is not None:
            plan.append((split, s.options.for_technique(split)[0]))
        want_ref = s.view == "diff" and self.ref_stash.key != key and (
            self.scripted or time.perf_counter() - self.key_since >= REF_SETTLE_S)
        if want_ref:
            plan.append((self.reference, self.reference.Options()))
        self._announce_slow(plan, lights, cam)
        if want_ref:
            self._render_other(self.ref_stash, self.reference, self.reference.Options(), lights,
                               fc, size, figures=False)
            self.ref_stash.key = key
        split_fig = None
        if split is not None:
            split_fig = self._render_other(self.split_stash, split, plan[1][1], lights, fc, size)

        self.warning = ""                    # announced (and rendered): said
        debug_pixel = self._cursor_pixel(size) if s.inspect else None
        t0 = time.perf_counter()
        result = r.render(tech, self.path_frame, opts, frames=self.args.path_frames, lights=lights,
                          readback=False, camera=fc,
                          debug_pixel=None if debug_pixel is None else (debug_pixel[0], size[1] - 1 - debug_pixel[1]))
        ref_valid = s.view == "diff" and self.ref_stash.key == key
        stats, extra = self._view_stats(ref_valid)
        render_ms = (time.perf_counter() - t0) * 1e3
        self.overlay = Overlay.of(result.build.grid)
        if s.view == "maps":
            self._upload_map(tech, result, size)
        exposure = images.exposure_from_histogram(extra["hist"]) if s.exposure_auto else s.exposure_manual
        s.exposure_now = exposure
        self.inspection = self._inspect(result, debug_pixel, size) if debug_pixel is not None else None
        self.figures = self._figures(result, stats, extra, cam, exposure, ref_valid, split_fig)
        if s.view == "maps":
            self.figures["map"] = self.map_shown[0]
        self.view_shown = s.view
        self.uniforms = self._present_uniforms(fc, size, exposure, ref_valid, split_fig)
        self._draw(self.wnd.fbo, self._buffer_size())
        config = (tech.name, tuple(sorted(opts.as_dict().items())), self._lights_key(), size)
        if config in self.seen:          # its first frame compiles: not a measure
            self.costs.record(tech.name, render_ms, size[0] * size[1], len(lights))
        self.seen.add(config)
        if self.playing:
            self.path_frame += 1
        self.frame += 1
        if self.shot_pending:
            self.shot_pending = False
            name = f"window-{self.scene.name}-{tech.name}-{s.view}-{self.frame:05d}.png"
            self._write_screenshot(Path(self.args.shot_dir) / name)
        wall_ms = (time.perf_counter() - t_start) * 1e3
        self.timers.add(config, result.meta["gpu_ms"], result.meta["cpu_ms"], wall_ms)
        self.figures["wall_ms"] = round(wall_ms, 2)
        rerender = lambda: (r, tech, opts, r.render(tech, self.path_frame, opts, frames=self.args.path_frames,
                                                   lights=lights, readback=False, camera=fc, figures=True))
        self.model.update((config, key), time.perf_counter() - self.key_since, self.scripted, rerender)
        self.figures["model"] = self.model.line((config, key))
        self._record(step)
        if self.args.frames is not None and self.frame >= self.args.frames:
            if self.args.screenshot:
                self._write_screenshot(self.args.screenshot)
            self.wnd.close()

    def _announce_slow(self, plan, lights, cam) -> None:
        """For each technique this frame renders: its predicted frame time; over SLOW_MS the
        HUD says so, on a frame shown before the slow one starts."""
        size = self.renderer.size
        self.warning = ""
        slow = []
        for t, opts in plan:
            k = (t.name, self._lights_key(), size)
            if k in self.announced:
                continue
            self.announced.add(k)
            try:
                ms = self.costs.estimate(self.renderer, t, opts, lights, cam)
            except UserError:
                continue
            if ms > probe.SLOW_MS:
                slow.append(f"{t.name} needs about {ms / 1000:.1f} s a frame at {size[0]}x{size[1]}")
        if not slow:
            return
        self.warning = "slow: " + "; ".join(slow) + " (rendering ...)"
        self.say(self.warning, 2 * MESSAGE_S)
        fbo = self.wnd.fbo
        fbo.use()
        fbo.clear(0.08, 0.08, 0.1, 1.0)
        self.ui.frame(self, fbo, self._buffer_size(), for_shot=True)
        if self.wnd.name != "headless":
            self.wnd.swap_buffers()

    def _render_other(self, stash, technique, opts, lights, fc, size, figures: bool = True) -> dict | None:
        """Render another technique's frame and stash its radiance and counters; with
        `figures`, its frame sums for the HUD too (the split view's; the reference's are
        not shown)."""
        r = self.renderer
        res = r.render(technique, self.path_frame, opts, frames=self.args.path_frames,
                       lights=lights, readback=False, camera=fc)
        stash.ensure(size)
        r.gbuffer.bind_textures()
        r.run([passes.stash_pass(stash.fbo, size)])
        if not figures:
            return None
        stats, extra = self._view_stats(False)
        covered = int(stats["covered"])
        total = lambda lo, hi: float(stats[lo]) + float(stats[hi]) * 2.0**32
        return {"technique": technique.name,
                "evaluated_per_pixel": total("evaluated_lo", "evaluated_hi") / covered if covered else 0.0,
                "exact_per_pixel": total("exact_lo", "exact_hi") / covered if covered else 0.0,
                "max_evaluated": int(stats["max_evaluated"]), "max_exact": extra["max_exact"],
                "cpu_ms": {k: round(float(v), 3) for k, v in res.meta["cpu_ms"].items()},
                "gpu_ms": {k: round(float(v), 3) for k, v in res.meta["gpu_ms"].items()}}

    def _view_stats(self, reference: bool):
        """The frame sums (one ViewStats) and the extra words (view_extra) of this frame."""
        r = self.renderer
        r.gbuffer.bind_textures()
        if reference:
            self.ref_stash.bind()
        r.run([passes.view_stats_pass(r.size, reference)])
        return r.read(passes.VIEW_STATS)[0], passes.read_extra(r.read(passes.VIEW_EXTRA))

    # ---- inspect ---------------------------------------------------------------------------------
    def _cursor_pixel(self, size):
        """The cursor as a render pixel, GL coordinates (None: off the image)."""
        if self.mouse is None:
            return None
        ww, wh = self.wnd.size
        x = int(self.mouse[0] * size[0] / max(ww, 1))
        y = size[1] - 1 - int(self.mouse[1] * size[1] / max(wh, 1))
        if not (0 <= x < size[0] and 0 <= y < size[1]):
            return None
        return x, y

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

    # ---- figures ----------------------------------------------------------------------------------
    def _figures(self, result, s, extra, cam, exposure, ref_valid, split_fig) -> dict:
        """The frame's figures: the HUD's, the title's and the JSON line's."""
        m = result.meta
        covered = int(s["covered"])
        total = lambda lo, hi: float(s[lo]) + float(s[hi]) * 2.0**32
        st = self.state
        _, ignored = st.options.for_technique(st.tech)
        return {
            "technique": m["technique"], "view": st.view, "lights": int(len(self._lights())),
            "visible_lights": int(m["stats"].get("visible_lights", len(result.build.lights.gpu))),
            "evaluated_per_pixel": total("evaluated_lo", "evaluated_hi") / covered if covered else 0.0,
            "exact_per_pixel": total("exact_lo", "exact_hi") / covered if covered else 0.0,
            "max_evaluated": int(s["max_evaluated"]), "max_exact": extra["max_exact"],
            "covered": covered, "lit": extra["lit"],
            "cpu_ms": {k: round(float(v), 3) for k, v in m["cpu_ms"].items()},
            "gpu_ms": {k: round(float(v), 3) for k, v in m["gpu_ms"].items()},
            "setup_ms": {k: round(float(v), 3) for k, v in m["setup_ms"].items()},
            "options": m["options"], "ignored_options": list(ignored),
            "grid": self.overlay.as_dict(),
            "exposure": round(float(exposure), 6), "exposure_auto": st.exposure_auto,
            "ambient": st.ambient, "heat_max": self._heat_top(s, extra, split_fig),
            "heat_of": st.heat_of, "heat_overlay": st.heat_overlay,
            "differ": extra["differ"] if ref_valid else None,
            "reference": self.reference.name if st.view == "diff" else None,
            "split": split_fig, "inspect": self.inspection.as_dict() if self.inspection else None,
            "size": list(self.renderer.size), "playing": self.playing, "path_frame": self.path_frame,
            "recording": len(self.recording) if self.recording is not None else None,
            "camera": [round(float(v), 3) for v in cam.position],
            "target": [round(float(v), 3) for v in cam.target],
        }

    def _heat_top(self, s, extra, split_fig) -> float:
        st = self.state
        if st.heat_max > 0:
            return float(st.heat_max)
        top = int(s["max_evaluated"]) if st.heat_of == "evaluated" else extra["max_exact"]
        if split_fig is not None:
            top = max(top, split_fig["max_evaluated"] if st.heat_of == "evaluated" else split_fig["max_exact"])
        return float(max(top, 1))

    def heat_scale(self):
        """(top, label) of the colour bar when the view shows a heat map or a technique's map
        (both log2(1 + n) on turbo), else None."""
        f = self.figures
        if not f:
            return None
        if self.view_shown == "maps":
            name, label, top = self.map_shown
            return (float(top), f"{name}: {label}, log2(1 + n)") if name else None
        heat = self.view_shown == "heat" or (self.view_shown == "split" and self.state.split_view == "heat")
        if not heat:
            return None
        what = "lights evaluated" if f["heat_of"] == "evaluated" else "exact lights"
        fixed = "fixed" if self.state.heat_max > 0 else "frame max"
        return f["heat_max"], f"{what} / pixel, log2(1 + n); top {f['heat_max']:g} ({fixed})"

    def _present_uniforms(self, fc, size, exposure, ref_valid, split_fig) -> dict:
        s = self.state
        o = self.overlay
        ins = self.inspection
        tile = (-1, -1, -1, -1)
        if ins is not None and ins.tile is not None:
            tile = ins.tile
        return {"u_exposure": float(exposure), "u_ambient": float(s.ambient),
                "u_heat_max": float(self.figures["heat_max"]),
                "u_heat_of": HEAT_OF.index(s.heat_of), "u_heat_overlay": int(s.heat_overlay),
                "u_tile": o.tile, "u_slices": o.slices, "u_slice_scale": o.slice_scale,
                "u_slice_bias": o.slice_bias, "u_ref_valid": int(ref_valid),
                "u_split_x": self._split_x(size) if split_fig is not None else size[0] + 1,
                "u_split_view": VIEWS.index(s.split_view),
                "u_cursor_tile": tuple(int(v) for v in tile),
                "u_cursor": tuple(ins.pixel) if ins is not None else (-1, -1),
                "u_light_sphere": tuple(ins.sphere) if ins is not None and ins.sphere else (0.0, 0.0, 0.0, 0.0),
                "u_tan_half": (float(fc.tan_half_x), float(fc.tan_half_y)),
                "u_map_max": float(self.map_shown[2] or 1.0)}

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
        top = max(max(float(np.max(v)) for v, _ in maps.values() if np.size(v)), 1.0)
        w, h = size
        v = np.asarray(values, np.float32)
        ky, kx = -(-h // v.shape[0]), -(-w // v.shape[1])
        full = np.ascontiguousarray(np.repeat(np.repeat(v, ky, 0), kx, 1)[:h, :w][::-1])  # GL rows
        if self._map_tex is None or self._map_tex.size != (w, h):
            if self._map_tex is not None:
                self._map_tex.release()
            import moderngl
            self._map_tex = self.ctx.texture((w, h), 1, dtype="f4")
            self._map_tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._map_tex.write(full.tobytes())
        self.map_shown = (name, label, top)

    def _split_x(self, size) -> int:
        """The split's column: split_at of the width, or (0, auto) the middle of what the
        panel leaves visible."""
        s = self.state
        if s.split_at > 0:
            return int(round(s.split_at * size[0]))
        hidden = 0.0
        if s.hud and s.panel:
            ww = max(int(self.wnd.size[0]), 1)
            hidden = min(self.ui.panel_width(ww), ww) / ww
        return int(round((1.0 - hidden) / 2 * size[0]))

    # ---- drawing -----------------------------------------------------------------------------------
    def _draw(self, target, viewport, for_shot: bool = False) -> None:
        """The current view and the UI over it into `target` (a moderngl framebuffer)."""
        r = self.renderer
        self.wnd.title = title(self.figures)
        r.gbuffer.bind_textures()
        self.ref_stash.bind()
        self.split_stash.bind()
        if self._map_tex is not None:
            self._map_tex.use(passes.UNITS["MAP_UNIT"])
        r.run([passes.present_pass(target, r.size, viewport, self.view_shown, self.uniforms)])
        self.ui.frame(self, target, viewport, for_shot=for_shot)

    def hud_lines(self, with_message: bool = True) -> list[str]:
        f, s = self.figures, self.state
        message = self.message if with_message and self.message and time.perf_counter() < self.message_until else ""
        warning = ("!" + self.warning) if self.warning else ""
        w, h = self.renderer.size
        ms = self.costs.predict(s.technique, w * h, s.lights)
        if not warning and ms is not None and ms > probe.SLOW_MS:
            warning = f"!slow: {s.technique} takes about {ms / 1000:.1f} s a frame here"
        if not f:
            return [l for l in (warning, message) if l] or ["starting ..."]
        status = []
        if self.recording is not None:
            status.append(f"REC {len(self.recording)} keys")
        if self.path is not None and self.playing:
            status.append(f"replay {self.path_frame % len(self.path) + 1}/{len(self.path)}")
        map_name, map_label, map_top = self.map_shown
        note = view_note(f["view"], s.technique, self.overlay, f["heat_max"], heat_of=f["heat_of"],
                         overlay_mode=f["heat_overlay"], reference=self.reference.name,
                         differ=f["differ"], split=s.split_with, split_view=s.split_view,
                         map_name=map_name, map_label=map_label, map_top=map_top)
        lines = hud_lines(f, position=f"{self.names.index(s.technique) + 1}/{len(self.names)}",
                          role=s.tech.role, software=self.renderer.limits.software,
                          playing=self.playing, options=s.options.hud_line(s.tech), note=note,
                          message=message, exposure=exposure_text(f["exposure"], s.exposure_auto, s.ambient),
                          status="   ".join(status), warning=warning)
        if s.panel:
            lines = [l for l in lines if l != HELP]     # the panel lists the keys
        if s.inspect:
            lines += (["inspect: " + l for l in self.inspection.lines(most=10)] if self.inspection
                      else ["inspect: move the cursor over the image"])
        if f.get("split"):
            sp = f["split"]
            lines.insert(2, f"right: {sp['technique']}   evaluated/px {sp['evaluated_per_pixel']:.2f}   "
                            f"GPU {sum(sp['gpu_ms'].values()):.1f} ms   CPU {sum(sp['cpu_ms'].values()):.1f} ms")
        return lines

    def technique_lines(self) -> list[str]:
        s = self.state
        out = [f"{s.technique}: {s.tech.summary}"]
        if self.started and self.frame < 600:
            out.append(self.started)
        w, h = self.renderer.size
        ms = self.costs.predict(s.technique, w * h, s.lights)
        if ms is not None:
            out.append(f"about {ms:.0f} ms a frame here" + ("  (slow)" if ms > probe.SLOW_MS else ""))
        return out

    def camera_lines(self) -> list[str]:
        src = (f"replay {self.args.replay} ({len(self.path)} keys)" if self.path is not None
               else f"the scene's path ({self.args.path_frames} frames)")
        out = [f"path: {src}", "playing, frame %d" % self.path_frame if self.playing else "stopped"]
        if self.recording is not None:
            out.append(f"recording: {len(self.recording)} keys" + (f" -> {self.record_to}" if self.record_to else ""))
        out += [f"saved: {p}" for p in self.saved_paths[-2:]]
        return out

    def inspect_lines(self) -> list[str]:
        if not self.state.inspect:
            return ["off (I): the light and the tile under the cursor"]
        if self.inspection is None:
            return ["move the cursor over the image"]
        return self.inspection.lines()

    def _write_screenshot(self, path) -> None:
        """Draw the current frame again into an offscreen framebuffer and save it (the
        window's own back buffer is not readable on every window type); the screenshot
        carries no transient message (the last screenshot's name, ...)."""
        from PIL import Image
        size = self._buffer_size()
        if self._shot_fbo is None or self._shot_fbo.size != size:
            if self._shot_fbo is not None:
                self._shot_fbo.release()
            self._shot_fbo = self.ctx.simple_framebuffer(size, components=4)
        self._shot_fbo.use()
        self._shot_fbo.clear(0.0, 0.0, 0.0, 1.0)
        self._draw(self._shot_fbo, size, for_shot=True)
        self.shot_huds.append(self.hud_lines(with_message=False) if self.state.hud else [])
        w, h = size
        rgb = np.frombuffer(self._shot_fbo.read(components=3, alignment=1), np.uint8).reshape(h, w, 3)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        Image.fromarray(np.ascontiguousarray(rgb[::-1])).save(path)
        self.say(f"screenshot: {path}")
        self.shots.append(str(path))
        self.wnd.fbo.use()

    def _record(self, step) -> None:
        f = dict(self.figures, frame=self.frame - 1, key=step)
        self.history.append({k: f[k] for k in ("technique", "view", "lights", "size")})
        if self.log:
            f["evaluated_per_pixel"] = round(f["evaluated_per_pixel"], 4)
            f["exact_per_pixel"] = round(f["exact_per_pixel"], 4)
            print(json.dumps(f), flush=True)

    def finish(self) -> None:
        """After the loop: the recording is saved (the window may be gone)."""
        if self.recording is not None:
            self._save_recording()
