"""The window itself: a moderngl-window WindowConfig that wires the parts together.

    keys.py      the key table: key names, help, dispatch (the key_* handlers below)
    compose.py   FrameComposer: renders the frame(s) the view needs, draws the view
    figures.py   the frame's figures and the UIModel that app.window.ui reads
    recorder.py  PathRecorder: the camera path played and recorded
    panel.py     the state a frame renders, and the one way values get in

A frame: last frame's panel changes and the next scripted step, the fly camera, its scale
(scale.py), the composer's frame, the figures, the view and the UI drawn, screenshots, the
JSON line.  A frame predicted to take more than probe.SLOW_MS is announced in the HUD (a
frame with the warning is shown) before it starts.

Dynamic resolution: a frame renders at DynamicScale's scale when the camera moves (it
changed since the last frame, a fly key or a mouse button is held) in the shaded view, and
at full size otherwise: at rest, in the views that show statistics (heat, tiles, diff,
split, maps ...), when inspecting, on a screenshot's frame, and on the first frame of a
configuration (technique, options, lights, size).  A reduced frame is presented at its
own size and scaled up to the window bilinearly (compose.FrameComposer.draw).  A reduced
frame's statistics are not shown or logged: its figures carry the last full-size frame's
(STAT_KEYS, with `stats_frame` saying which), and only full-size frames reach the timers,
the frame costs and the modelled GPU time.
"""
from __future__ import annotations

import json
from pathlib import Path
import sys
import time

import moderngl_window as mglw
import numpy as np

from cpu_prep.camera import frame_camera
from scenes.motion import lights_at

from ..errors import UserError
from ..pipeline import gl
from ..pipeline.renderer import Renderer
from ..techniques import REGISTRY, with_role
from . import keys, probe, progress
from .camera import FlyCamera
from .compose import REF_SETTLE_S, FrameComposer, Screenshots
from .figures import UIModel, frame_figures, heat_scale
from .fog_view import (FROXEL_VIEW, LAYERS_VIEW, fog_figures, scene_views, transparent_figures,
                       window_renderer)
from .stereo_view import StereoComposer, eye_size, refusal as stereo_refusal
from .. import stereo
from ..pipeline.fog import refusal as fog_refusal
from .hud import inspect_lines, technique_lines, title, window_hud
from .keys import CHAR_KEYS, MOVE_KEYS
from .lightsets import LightSets
from .model import FrameModel
from ..given_options import GivenOptions
from .panel import LabState, Panel
from .recorder import PathRecorder
from .scale import DynamicScale, scaled_size
from .timers import Timers
from .ui import LabUI

REPLAY_STEP_S = 0.25          # a replayed W/A/S/D/Q/E moves this many seconds' worth
MESSAGE_S = 3.0
STARTED_FRAMES = 600          # the panel says how the start chose the technique this long
# the figures a reduced frame takes from the last full-size one (frame_figures' statistics)
STAT_KEYS = ("visible_lights", "evaluated_per_pixel", "exact_per_pixel", "max_evaluated",
             "max_exact", "covered", "lit", "cpu_ms", "cpu_threads", "gpu_ms", "setup_ms",
             "capped", "grid", "heat_max", "stereo", "transparent", "fog")


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
        feats = self.features = setup.get("features") or {"stereo": False, "way": "per-view",
                                                          "separation": stereo.DEFAULT_SEPARATION,
                                                          "fog": None}
        self.renderer = window_renderer(self.scene, self._buffer_size(), feats["fog"],
                                        getattr(a, "transparent_layers", None))
        self.reference = with_role("reference")
        self.state = self._initial_state(setup)
        self.state.target_fps, self.state.move_scale = a.target_fps, a.move_scale
        self.panel = Panel(self.state, actions={
            "play": ("play / stop the path (P)", lambda: self.key_play("p")),
            "record": ("record / stop and save (C)", lambda: self.key_record("c")),
            "reset_camera": ("reset the camera (R)", lambda: self.key_reset("r")),
            "screenshot": ("screenshot (K)", lambda: self.key_screenshot("k"))})
        self.lights = LightSets(self.scene, a.scene, self.state)
        self.cam = FlyCamera(self.scene.camera)
        self.speed = max(float(self.scene.max_depth or self.scene.camera.far) / 40.0, 1.0)   # m/s
        self.recorder = PathRecorder(self.scene, a, self.say)
        self.composer = FrameComposer(self.ctx, self.renderer, self.reference)
        self.composer.hold = self.scene.fog is not None and getattr(a, "fog_hold", True)
        self.stereo = StereoComposer(self.ctx, self.composer, feats["way"], feats["separation"])
        self.composed = None              # the last frame's compose.Composed
        self.figures: dict = {}
        self.ui = LabUI(self.wnd)
        self.key_codes = keys.key_names(self.wnd.keys)
        if self.wnd.name != "headless":
            self.wnd.exit_key = None          # Esc is ours: it may take the screenshot first
        self.held: set[str] = set()
        self.replay = list(a.keys)
        self.scripted = a.frames is not None or bool(a.keys)
        self.frame, self.frame_dt = 0, 1 / 60
        self.full_size = self._buffer_size()
        self.scaler = DynamicScale(a.target_fps, a.move_scale)
        self.scale = 1.0                  # the shown frame's
        self.rest: tuple | None = None    # the last full-size frame: (config, figures, frame)
        self.last_view = None             # the last frame's camera (scale: moving or not)
        self.dragging = False             # a mouse button held over the image
        self.quitting = False             # Esc with --screenshot on a reduced frame
        self.mouse = self._parse_cursor(a.cursor)
        self.message, self.message_until, self.warning = "", 0.0, ""
        self.shots = Screenshots(self.ctx)
        self.history: list[dict] = []
        self.timers, self.model, self.costs = Timers(), FrameModel(), probe.FrameCosts()
        self.seen: set = set()
        self.started: list[str] = []      # how the start chose the technique (probe.choose_start)
        if setup["technique"] is None:
            self._start_fastest(setup["candidates"])
        self.state.split_with = self.state.default_split()
        self.state.scene_views = scene_views(self.scene)
        self.state.refusal = self._refusal
        self.composer.froxels.k = getattr(a, "froxel_slice", 0)
        if feats["stereo"]:
            self._set_stereo(True)
        if self.state.view not in self.state.views():
            raise UserError(f"--view {self.state.view}: {self.state.technique} has no such view")
        self.state.version = 0
        if self.recorder.record_to is not None:
            self.recorder.toggle_record(self.full_size)

    # ---- start-up -------------------------------------------------------------------------
    def _initial_state(self, setup) -> LabState:
        a = self.args
        n = len(self.scene.lights)
        s = LabState(REGISTRY, technique=setup["technique"] or setup["candidates"][0],
                     options=GivenOptions(setup["given"]), lights=n, view=a.view, seed=a.seed,
                     distribution=a.distribution, builtin=setup["builtin"], file_lights=n,
                     heat_max=a.heat_max, ambient=a.ambient, hud=not a.no_hud,
                     inspect=a.cursor is not None)
        if a.exposure != "auto":
            s.exposure_auto, s.exposure_ev = False, float(np.log2(float(a.exposure)))
        return s

    def _start_fastest(self, candidates) -> None:
        self.state.technique, self.started = probe.choose_start(
            self.args, self.renderer, candidates, self.state.options,
            lambda: self.lights.of(self.state), self.scene.camera, self.costs)
        if len(candidates) > 1:
            for line in self.started:
                progress.say(line)

    @staticmethod
    def _parse_cursor(text):
        if not text:
            return None
        x, y = (int(v) for v in text.lower().split("x"))
        return (x, y)

    def _buffer_size(self):
        w, h = self.wnd.buffer_size
        return max(int(w), 1), max(int(h), 1)

    def say(self, text: str, seconds: float = MESSAGE_S) -> None:
        self.message, self.message_until = text, time.perf_counter() + seconds
        print(text, file=sys.stderr, flush=True)

    def _move(self, axes, dt: float, fast: bool = False) -> None:
        d = self.speed * dt * (4.0 if fast else 1.0)
        self.cam.move(axes[0] * d, axes[1] * d, axes[2] * d)

    # ---- key handlers (keys.KEYS names them; each takes the key name) -------------------------
    def key_technique(self, name: str) -> None:
        self.state.choose_number(int(name))

    def key_next_technique(self, _: str) -> None:
        self.state.next_technique()

    def key_view(self, _: str) -> None:
        self.state.next_view()

    def key_overlay(self, _: str) -> None:
        s = self.state
        s.heat_overlay = not s.heat_overlay
        if s.view != "heat" and "heat" in s.views():
            s.view = "heat"
        s.changed()

    def key_inspect(self, _: str) -> None:
        self.state.inspect = not self.state.inspect
        self.state.changed()

    def key_stereo(self, _: str) -> None:
        self._set_stereo(not self.state.stereo)

    def _set_stereo(self, on: bool) -> None:
        """Both eyes side by side (stereo_view.py) or one view; a view or inspect that needs
        the mono frame is left for shaded / off, and said."""
        s = self.state
        if on:
            opts = s.options.for_technique(s.tech)[0]
            why = stereo_refusal(self.scene, s.tech, opts, self.stereo.way)
            if why:
                raise UserError(why)
        s.stereo = on
        notes = []
        if s.view not in s.views():
            notes.append(f"{s.view} is a mono view: shaded")
            s.view = "shaded"
        if on and s.inspect:
            s.inspect = False
            notes.append("inspect is mono only: off")
        s.changed("; ".join([f"stereo {self.stereo.way}" if on else "mono"] + notes))

    def _refusal(self, tech, opts) -> str | None:
        """Why `tech` with `opts` cannot render this scene in this window: a fog scene's
        froxels (app.pipeline.fog), stereo's way; None when it can."""
        why = None
        if self.scene.fog is not None:
            why = fog_refusal(tech, tech.resolve_options(opts), self.renderer.fog_options)
        if why is None and self.state.stereo:
            why = stereo_refusal(self.scene, tech, opts, self.stereo.way)
        return why

    def key_froxel_slice(self, name: str) -> None:
        if self.scene.fog is None:
            raise UserError("froxel slices: the scene has no fog (hangar-fog has)")
        shown = self.composer.froxels.shown
        self.composer.froxels.step(1 if name == ">" else -1, shown[1] if shown else None)
        if self.state.view != FROXEL_VIEW:
            self.state.view = FROXEL_VIEW
        self.state.changed()

    def key_next_map(self, _: str) -> None:
        s = self.state
        if "maps" not in s.views():
            raise UserError(f"{s.technique} has no maps of its own")
        self.composer.map_index += s.view == "maps"     # the first M shows the first map
        s.view = "maps"
        s.changed()

    def key_fly(self, name: str) -> None:
        """A scripted W/A/S/D/Q/E: one step of REPLAY_STEP_S (held keys fly in on_render)."""
        self.recorder.stop_for(self.cam)
        self._move(MOVE_KEYS[name], REPLAY_STEP_S)

    def key_play(self, _: str) -> None:
        self.recorder.toggle_play(self.cam)

    def key_record(self, _: str) -> None:
        self.recorder.toggle_record(self.full_size)

    def key_reset(self, _: str) -> None:
        self.recorder.reset(self.cam)

    def key_lights(self, name: str) -> None:
        if name in ("+", "]"):
            self.state.double_lights()
        else:
            self.state.halve_lights()

    def key_screenshot(self, _: str) -> None:
        self.shots.pending = True

    def key_hide(self, _: str) -> None:
        self.state.hud = not self.state.hud
        self.state.changed()

    def key_panel(self, _: str) -> None:
        self.state.panel = not self.state.panel
        self.state.changed()

    def key_quit(self, _: str) -> None:
        if self.args.screenshot and self.frame:
            if self.scale < 1.0:          # a reduced frame on screen: one full-size frame first
                self.quitting = True
                return
            self._write_screenshot(self.args.screenshot)
        self.wnd.close()

    def press(self, name: str) -> None:
        """One key press, by key name (keys.KEY_NAMES); a refusal is shown, not raised."""
        try:
            keys.dispatch(self, name)
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
            self.press(step)

    # ---- moderngl-window events ----------------------------------------------------------------
    def on_key_event(self, key, action, modifiers):
        self.ui.forward("key_event", key, action, modifiers)
        name = self.key_codes.get(key)
        if name is None or (self.ui.want_keyboard and name != "escape"):
            return
        if action == self.wnd.keys.ACTION_PRESS:
            if keys.ROWS[name].held:
                self.held.add(name)
                self.recorder.stop_for(self.cam)
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
        self.recorder.stop_for(self.cam)
        self.cam.turn(dx * 0.004, -dy * 0.004)

    def on_mouse_press_event(self, x, y, button):
        self.ui.forward("mouse_press_event", x, y, button)
        self.dragging = not self.ui.want_mouse          # a drag looks around: moving

    def on_mouse_release_event(self, x, y, button):
        self.ui.forward("mouse_release_event", x, y, button)
        self.dragging = False

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
        step = self._take_inputs()
        if self.wnd.is_closing:
            return
        self._fly(frame_time)
        size = self.full_size = self._buffer_size()
        cam = self.recorder.camera(self.cam)
        self.recorder.add(cam)
        # the lights of the path frame shown: they move while a path plays (scenes.motion)
        lights = lights_at(self.lights.of(self.state), self.scene.motion, self.recorder.frame,
                           self.args.path_frames)
        tech = self.state.tech
        opts = self.state.options.for_technique(tech)[0]
        config = (tech.name, tuple(sorted(opts.as_dict().items())), LightSets.key(self.state), size,
                  self.state.stereo)
        self.scale = self._frame_scale(cam, config)
        full = self.scale >= 1.0
        render_size = scaled_size(eye_size(size) if self.state.stereo else size, self.scale)
        if render_size != self.renderer.size:
            self.renderer.resize(render_size)
        plan, c, fc, key = self._compose(cam, lights, render_size)
        self._scale_figures(config, render_size)
        if not self.state.stereo:
            self.figures["model"] = self.model.line((config, key))     # the HUD shows it this frame
        self._draw(self.wnd.fbo, size)
        held = self.composer.held_since is not None      # a fog frame shown again: no measure
        if full and config in self.seen and not held and not self.state.stereo:
            self.costs.record(tech.name, c.render_ms, size[0] * size[1], len(lights))
        if config not in self.seen or self.shots.pending or held:
            self.scaler.skip()                    # compiles, saves, a held frame: not a frame's time
        self.seen.add(config)
        shown_frame = self.recorder.frame
        self.recorder.advance()
        self.frame += 1
        if self.shots.pending:
            self.shots.pending = False
            name = f"window-{self.scene.name}-{tech.name}-{self.state.view}-{self.frame:05d}.png"
            self._write_screenshot(Path(self.args.shot_dir) / name)
        wall_ms = (time.perf_counter() - t_start) * 1e3
        if full and not held:
            self.timers.add(config, c.result.meta["gpu_ms"], c.result.meta["cpu_ms"], wall_ms)
        self.figures["wall_ms"] = round(wall_ms, 2)
        r = self.renderer
        rerender = lambda: (r, tech, opts, r.render(tech, shown_frame, opts, frames=self.args.path_frames,
                                                   lights=lights, readback=False, camera=fc, figures=True))
        t_model = time.perf_counter()
        if full and not self.state.stereo and self.model.update((config, key), self.composer.still_s(key), self.scripted, rerender):
            self.scaler.exclude(time.perf_counter() - t_model)     # the replay: not the frame's time
        if not self.state.stereo:
            self.figures["model"] = self.model.line((config, key))
        self._log(step)
        if self.quitting:
            self._write_screenshot(self.args.screenshot)
            self.wnd.close()
        elif self.args.frames is not None and self.frame >= self.args.frames:
            if self.args.screenshot:
                self._write_screenshot(self.args.screenshot)
            self.wnd.close()

    def _frame_scale(self, cam, config) -> float:
        """This frame's scale (the module's docstring says when it may be reduced)."""
        view = (tuple(cam.position), tuple(cam.target), tuple(cam.up), cam.fov_y_deg)
        moving = (self.last_view is not None and view != self.last_view) or bool(self.held) or self.dragging
        self.last_view = view
        s, a = self.state, self.args
        self.scaler.target_fps, self.scaler.fixed = s.target_fps, s.move_scale
        last_shot = a.screenshot and a.frames is not None and self.frame + 1 >= a.frames
        shaded = s.view == "shaded" and not s.inspect
        full = (not shaded or self.shots.pending or self.quitting or last_shot
                or self.rest is None or self.rest[0] != config)
        scale = self.scaler.next(moving and not full)
        if not shaded:
            self.scaler.skip()        # renders more than a shaded frame: not what moving costs
        return scale

    def _scale_figures(self, config, render_size) -> None:
        """The frame's scale in its figures; a full-size frame is the one statistics come
        from (self.rest), a reduced one takes them from it."""
        f, s = self.figures, self.state
        f.update(scale=self.scale, render_size=list(render_size), target_fps=s.target_fps,
                 move_scale=s.move_scale, frame_ms=None if self.scaler.last_s is None
                 else round(self.scaler.last_s * 1e3, 1))
        if self.scale >= 1.0:
            self.rest = (config, dict(f), self.frame)
        else:
            f.update({k: self.rest[1][k] for k in STAT_KEYS})
        f["stats_frame"] = self.rest[2]

    def _take_inputs(self):
        """Last frame's panel changes, then this frame's scripted step (returned)."""
        for key, value in self.ui.take_queued():
            self._apply(key, value)
        step = self.replay.pop(0) if self.replay else None
        if step is not None:
            self._script_step(step)
        for m in self.state.messages:
            self.say(m)
        self.state.messages.clear()
        return step

    def _fly(self, frame_time: float) -> None:
        dt = min(max(frame_time, 0.0), 0.1)
        fast = bool(getattr(self.wnd.modifiers, "shift", False))
        for k in self.held:
            self._move(MOVE_KEYS[k], dt, fast)

    def _compose(self, cam, lights, size):
        """This frame through the composer at render size `size`: (plan, Composed, frame
        camera, view key: of the full size); the figures and the present pass's uniforms
        follow from it."""
        s = self.state
        fc = frame_camera(cam, *size)
        key = (tuple(cam.position), tuple(cam.target), tuple(cam.up), cam.fov_y_deg,
               LightSets.key(s), self.full_size, self.recorder.frame if self.scene.motion else 0)
        settled = self.scripted or self.composer.still_s(key) >= REF_SETTLE_S
        plan = self.composer.plan(s, key, settled)
        self._announce_slow(plan.renders(), lights, cam)
        self.warning = ""                    # announced (and rendered): said
        debug_pixel = self._cursor_pixel(size) if s.inspect else None
        frame = (lights, fc, size, self.recorder.frame, self.args.path_frames, self.frame)
        st = None
        if s.stereo:
            c, st = self.stereo.render(plan, s, frame, self.scene, key)
        else:
            c = self.composer.render(plan, s, frame, key, debug_pixel)
        self.composed = c
        self.figures = frame_figures(c, s, lights=int(len(lights)), size=self.full_size,
                                     recorder=self.recorder, cam=cam, reference=self.reference.name)
        m = c.result.meta
        self.figures.update(stereo=st, transparent=transparent_figures(m),
                            fog=fog_figures(m, self.features["fog"], self.composer.held_since))
        if s.view == FROXEL_VIEW:
            self.figures["scene_note"] = self.composer.froxels.note()
            self.figures["froxel_slice"] = self.composer.froxels.figures()
        elif s.view == LAYERS_VIEW:
            self.figures["scene_note"] = self.composer.layers_note
            self.figures["layers_top"] = self.composer.map_shown[2]
        if s.stereo:
            self.figures["model"] = "modelled GPU ms: mono frames only (B)"
            return plan, c, fc, key
        if s.view == "maps":
            self.figures["map"] = self.composer.map_shown[0]
        self.composer.present(c, s, fc, size, self.figures["heat_max"], self._split_x(size))
        return plan, c, fc, key

    def _announce_slow(self, plan, lights, cam) -> None:
        """For each technique this frame renders: its predicted frame time; over SLOW_MS the
        HUD says so, on a frame shown before the slow one starts."""
        self.warning = ""
        slow = self.costs.slow(self.renderer, plan, LightSets.key(self.state), lights, cam)
        if not slow:
            return
        if self.state.stereo:                # the renderer is at one eye's size
            slow = [f"{line} per eye, two eyes a frame" for line in slow]
        self.warning = "slow: " + "; ".join(slow) + " (rendering ...)"
        self.say(self.warning, 2 * MESSAGE_S)
        fbo = self.wnd.fbo
        fbo.use()
        fbo.clear(0.08, 0.08, 0.1, 1.0)
        self.ui.frame(self.ui_model(for_shot=True), fbo, self._buffer_size(), for_shot=True)
        if self.wnd.name != "headless":
            self.wnd.swap_buffers()

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

    # ---- what the UI shows -----------------------------------------------------------------------
    def ui_model(self, for_shot: bool = False) -> UIModel:
        """The UI's model of this frame; for_shot: a screenshot's, without transient messages
        (the last screenshot's name, ...)."""
        s, c = self.state, self.composed
        w, h = self.full_size
        predicted = self.costs.predict(s.technique, w * h, s.lights)
        now = time.perf_counter() < self.message_until
        message = self.message if not for_shot and now else ""
        hud = window_hud(self.figures, s, message=message, warning=self.warning, predicted_ms=predicted,
                         status=self.recorder.status(), playing=self.recorder.playing,
                         software=self.renderer.limits.software, map_shown=self.composer.map_shown,
                         overlay=c.overlay if c else None, reference=self.reference.name,
                         inspection=c.inspection if c else None)
        started = self.started if self.frame < STARTED_FRAMES else []
        return UIModel(
            hud=s.hud, panel=s.panel, hud_lines=hud, controls=self.panel.controls(),
            section_lines={"technique": technique_lines(s, started, predicted),
                           "camera": self.recorder.lines(),
                           "inspect": inspect_lines(s, c.inspection if c else None)},
            timers=self.timers.rows(),
            heat_scale=heat_scale(self.figures, self.composer.view_shown, s, self.composer.map_shown),
            keys=keys.HELP, frame_dt=self.frame_dt, legend=self.composer.variant_legend())

    def _draw(self, target, viewport, for_shot: bool = False) -> UIModel:
        """The current view and the UI over it into `target` (a moderngl framebuffer)."""
        if self.figures:
            self.wnd.title = title(self.figures)
        if self.state.stereo and self.composed is not None:
            self.stereo.draw(target, viewport)
        else:
            self.composer.draw(target, viewport)
        model = self.ui_model(for_shot)
        self.ui.frame(model, target, viewport, for_shot=for_shot)
        return model

    def _write_screenshot(self, path) -> None:
        """The current frame drawn again and saved; it carries no transient message (the
        last screenshot's name, ...)."""
        size = self._buffer_size()
        path = self.shots.take(size, lambda fbo: self._draw(fbo, size, for_shot=True), path)
        self.say(f"screenshot: {path}")
        self.wnd.fbo.use()

    def _log(self, step) -> None:
        """The frame in the run's history (the summary's sequence), and its JSON line."""
        f = dict(self.figures, frame=self.frame - 1, key=step)
        self.history.append({k: f[k] for k in ("technique", "view", "lights", "size")})
        if self.args.json or self.args.frames is not None:
            f["evaluated_per_pixel"] = round(f["evaluated_per_pixel"], 4)
            f["exact_per_pixel"] = round(f["exact_per_pixel"], 4)
            print(json.dumps(f), flush=True)

    def finish(self) -> None:
        """After the loop: the recording is saved (the window may be gone)."""
        if self.recorder.recording is not None:
            self.recorder.save()
