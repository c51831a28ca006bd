"""The window's user interface, in Dear ImGui (imgui-bundle) through moderngl-window's
integration (moderngl_window.integrations.imgui_bundle):

    HUD        top left: the frame's figures (app.window.hud), the messages
    panel      right: every control of app.window.panel (technique, its declared options,
               lights, display, compare, inspect, camera), the variants view's legend
               (app.window.variant_view: a swatch, the tiles and the mask each), the timers (rolling median, min
               and a history graph per GPU pass and CPU stage), the cursor's inspection
    colour bar bottom left, in the heat and maps views: app.images' ramp and ticks

A widget that changes does not change the state at once: it queues (key, value) for
Panel.apply at the start of the next frame (the frame on screen has rendered already), the
same path scripted runs take (--keys "tile=32"; "click:NAME" feeds imgui a mouse click at the
widget's place).  Works the same headless (EGL) and in a desktop window.

The UI reads one app.window.figures.UIModel a frame (the window builds it) and never the
window itself: what it shows is what the model holds.
"""
from __future__ import annotations

from collections import deque

import numpy as np

from .. import images
from ..errors import UserError
from .panel import Control

# moderngl-window 3.1's integration reads the font atlas with get_tex_data_as_rgba32, which
# imgui-bundle 1.92 removed (moderngl-window issue #222)
REQUIREMENT = "imgui-bundle>=1.6.3,<1.92"
SECTIONS = (("technique", "Technique", True), ("options", "Options", True),
            ("lights", "Lights", True), ("display", "Display", True), ("compare", "Compare", False),
            ("camera", "Camera path", False), ("inspect", "Inspect", False))
PANEL_WIDTH = 330
HUD_MARGIN = 24               # between the HUD and the panel (or the window's right edge)
HISTORY_SIZE = (0, 34)


def _pow2_choices(lo, hi) -> list[int]:
    out, v = [], 1
    while v <= (hi or 1 << 20):
        if v >= (lo or 1):
            out.append(v)
        v <<= 1
    return out


class LabUI:
    def __init__(self, wnd):
        try:
            import imgui_bundle
            from imgui_bundle import imgui
            from moderngl_window.integrations.imgui_bundle import ModernglWindowRenderer
        except ImportError as exc:
            raise UserError(f"the window's panel needs imgui-bundle ({exc}); "
                            f"pip install '{REQUIREMENT}'") from None
        version = tuple(int(v) for v in imgui_bundle.__version__.split(".")[:2] if v.isdigit())
        if version >= (1, 92):
            raise UserError(f"imgui-bundle {imgui_bundle.__version__} changed the font atlas API that "
                            f"moderngl-window's integration uses; pip install '{REQUIREMENT}'")
        self.imgui = imgui
        self.wnd = wnd
        self.context = imgui.create_context()
        imgui.get_io().set_ini_filename("")          # no imgui.ini beside the user's files
        imgui.style_colors_dark()
        self.renderer = ModernglWindowRenderer(wnd)
        self.rects: dict[str, tuple[float, float, float, float]] = {}
        self.queued: list[tuple[str, object]] = []  # (control key, value), applied next frame
        self.inputs: deque = deque()               # scripted mouse events, one group a frame
        self.want_mouse = False
        self.want_keyboard = False

    # ---- events (forwarded by the window) -------------------------------------------------
    def forward(self, name: str, *args) -> None:
        getattr(self.renderer, name)(*args)

    def click(self, key: str) -> bool:
        """Queue a mouse click at the widget of control `key` (its place in the last frame):
        move, press, release on three frames.  False when the widget is not on screen."""
        r = self.rects.get(key)
        if r is None:
            return False
        x, y = (r[0] + min(r[2], r[0] + 12)) / 2 + 2, (r[1] + r[3]) / 2
        self.inputs.extend([("pos", x, y), ("down",), ("up",)])
        return True

    def _feed_inputs(self) -> None:
        if not self.inputs:
            return
        io = self.imgui.get_io()
        ev = self.inputs.popleft()
        if ev[0] == "pos":
            io.add_mouse_pos_event(ev[1], ev[2])
        else:
            io.add_mouse_button_event(0, ev[0] == "down")

    # ---- one frame of UI ---------------------------------------------------------------------
    def frame(self, model, target, viewport, for_shot: bool = False) -> None:
        """Build the UI of `model` (figures.UIModel) and draw it into `target`.  for_shot:
        the screenshot's copy (no input, nothing queued)."""
        imgui = self.imgui
        io = imgui.get_io()
        w, h = viewport
        # imgui lays out in window coordinates (the mouse's); the target has `viewport` pixels
        ww, wh = (int(v) for v in self.wnd.size)
        ww, wh = max(ww, 1), max(wh, 1)
        io.display_size = (ww, wh)
        io.display_framebuffer_scale = (w / ww, h / wh)
        io.delta_time = max(float(model.frame_dt), 1e-3)
        if not for_shot:
            self._feed_inputs()
            self.rects = {}                        # the widgets on screen this frame
        imgui.new_frame()
        self.for_shot = for_shot
        if model.hud:
            self._hud(model, ww - (self.panel_width(ww) if model.panel else 0) - HUD_MARGIN)
            if model.panel:
                self._panel(model, ww, wh)
            self._colorbar(model, ww, wh)
        imgui.render()
        if not for_shot:
            self.want_mouse = bool(io.want_capture_mouse)
            self.want_keyboard = bool(io.want_text_input)
        target.use()
        ctx = self.wnd.ctx
        ctx.viewport = (0, 0, w, h)
        self.renderer.render(imgui.get_draw_data())
        ctx.scissor = None

    def take_queued(self) -> list[tuple[str, object]]:
        q, self.queued = self.queued, []
        return q

    # ---- pieces ---------------------------------------------------------------------------------
    def _hud(self, model, width: int) -> None:
        """The HUD's lines, wrapped at `width` (what the panel leaves): a line wider than the
        window would be cut off, the help line first."""
        imgui = self.imgui
        imgui.set_next_window_pos((0, 0))
        imgui.set_next_window_bg_alpha(0.6)
        flags = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.always_auto_resize |
                 imgui.WindowFlags_.no_inputs | imgui.WindowFlags_.no_saved_settings |
                 imgui.WindowFlags_.no_focus_on_appearing | imgui.WindowFlags_.no_nav)
        imgui.begin("hud", None, flags)
        imgui.push_text_wrap_pos(max(float(width), 80.0))
        for line in model.hud_lines:
            warning = line.startswith("!")
            if warning:
                imgui.push_style_color(imgui.Col_.text, imgui.ImVec4(1.0, 0.75, 0.2, 1.0))
            imgui.text_wrapped(line[1:] if warning else line)
            if warning:
                imgui.pop_style_color()
        imgui.pop_text_wrap_pos()
        imgui.end()

    @staticmethod
    def panel_width(w: int) -> int:
        return min(PANEL_WIDTH, max(int(w * 0.45), 120))

    def _panel(self, model, w: int, h: int) -> None:
        imgui = self.imgui
        pw = self.panel_width(w)
        imgui.set_next_window_pos((w - pw, 0))
        imgui.set_next_window_size((pw, h))
        imgui.set_next_window_bg_alpha(0.82)
        flags = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize |
                 imgui.WindowFlags_.no_saved_settings | imgui.WindowFlags_.no_collapse)
        imgui.begin("lab", None, flags)
        imgui.push_item_width(-110)
        for section, title, open_ in SECTIONS:
            if section == "options" and model.legend:      # under the technique, when shown
                self._legend(model.legend)
            mine = [c for c in model.controls if c.section == section]
            lines = model.section_lines.get(section, [])
            if not mine and not lines:
                continue
            imgui.set_next_item_open(open_, imgui.Cond_.once)
            if not imgui.collapsing_header(title):
                continue
            first = lines if section == "technique" else []      # the technique's text leads
            for line in first:
                imgui.text_wrapped(line)
            for c in mine:
                self._widget(c)
            for line in ([] if first else lines):
                imgui.text_wrapped(line)
        imgui.set_next_item_open(True, imgui.Cond_.once)
        if imgui.collapsing_header("Timers"):
            self._timers(model.timers)
        imgui.set_next_item_open(False, imgui.Cond_.once)
        if imgui.collapsing_header("Keys"):
            for k, what in model.keys:
                imgui.text_wrapped(f"{k:12} {what}")
        imgui.pop_item_width()
        imgui.end()

    def _widget(self, c: Control) -> None:
        imgui = self.imgui
        label = f"{c.label}##{c.key}"
        changed, value = False, c.value
        if c.kind == "choice":
            items = [str(v) for v in c.choices]
            idx = items.index(str(c.value)) if str(c.value) in items else 0
            changed, idx = imgui.combo(label, idx, items)
            value = c.choices[idx] if items else c.value
        elif c.kind == "bool":
            changed, value = imgui.checkbox(label, bool(c.value))
        elif c.kind == "button":
            changed = imgui.button(label)
            value = None
        elif c.kind == "int" and c.power_of_two:
            items = _pow2_choices(c.lo, c.hi)
            idx = items.index(c.value) if c.value in items else 0
            changed, idx = imgui.combo(label, idx, [str(v) for v in items])
            value = items[idx]
        elif c.kind == "int":
            lo, hi = int(c.lo if c.lo is not None else 0), int(c.hi if c.hi is not None else 1 << 30)
            if hi - lo > 100_000 and not c.log:
                changed, value = imgui.input_int(label, int(c.value))
            else:
                flags = imgui.SliderFlags_.logarithmic if c.log else 0
                changed, value = imgui.slider_int(label, int(c.value), lo, hi, "%d", flags)
        elif c.kind == "float":
            lo, hi = float(c.lo if c.lo is not None else 0.0), float(c.hi if c.hi is not None else 1.0)
            flags = imgui.SliderFlags_.logarithmic if c.log else 0
            changed, value = imgui.slider_float(label, float(c.value), lo, hi, "%.4g", flags)
        r0, r1 = imgui.get_item_rect_min(), imgui.get_item_rect_max()
        self.rects[c.key] = (r0.x, r0.y, r1.x, r1.y)
        if c.help:
            imgui.set_item_tooltip(c.help)
        if changed and not self.for_shot:
            self.queued.append((c.key, value))

    def _legend(self, entries) -> None:
        """The variants view's legend: per mask its colour's swatch, its tiles and the mask;
        a colour several masks share says why (grey: no lights, white: the general program)."""
        imgui = self.imgui
        imgui.set_next_item_open(True, imgui.Cond_.once)
        if not imgui.collapsing_header("Feature variants"):
            return
        imgui.text_wrapped("tiles  mask (one colour a program)")
        for i, e in enumerate(entries):
            rgb = imgui.ImVec4(*(c / 255.0 for c in e.rgb), 1.0)
            imgui.color_button(f"##variant{i}", rgb, imgui.ColorEditFlags_.no_tooltip, imgui.ImVec2(14, 14))
            imgui.same_line()
            imgui.text_wrapped(f"{e.tiles:5d}  {e.label}" + (f"  ({e.shares})" if e.shares else ""))

    def _timers(self, timers) -> None:
        imgui = self.imgui
        if not timers:
            imgui.text_wrapped("(history starts on the second frame of a configuration)")
            return
        imgui.text("median / min over the last frames, ms")
        for name, med, lo, n, history in timers:
            imgui.text(f"{name:18} {med:8.2f} {lo:8.2f}  ({n})")
            if history is not None:
                values = np.asarray(history, np.float32)
                if len(values) > 1:
                    imgui.plot_lines(f"##{name}", values, 0, None, 0.0, float(values.max()) * 1.1,
                                     imgui.ImVec2(*HISTORY_SIZE))

    def _colorbar(self, model, w: int, h: int) -> None:
        scale = model.heat_scale
        if scale is None:
            return
        vmax, label = scale
        imgui = self.imgui
        dl = imgui.get_foreground_draw_list()
        bw = min(320, int(w * 0.45))
        x0, y1 = 10, h - 22
        y0 = y1 - 12
        dl.add_rect_filled(imgui.ImVec2(x0 - 6, y0 - 20), imgui.ImVec2(x0 + bw + 14, h - 4),
                           imgui.get_color_u32(imgui.ImVec4(0, 0, 0, 0.6)))
        n = 64
        cols = images.turbo(np.linspace(0.0, 1.0, n + 1))
        u32 = [imgui.get_color_u32(imgui.ImVec4(float(c[0]), float(c[1]), float(c[2]), 1.0)) for c in cols]
        for i in range(n):
            a, b = x0 + bw * i / n, x0 + bw * (i + 1) / n
            dl.add_rect_filled_multi_color(imgui.ImVec2(a, y0), imgui.ImVec2(b + 0.5, y1),
                                           u32[i], u32[i + 1], u32[i + 1], u32[i])
        white = imgui.get_color_u32(imgui.ImVec4(1, 1, 1, 1))
        for v in images.heat_ticks(vmax):
            x = x0 + bw * float(images.heat_t(np.array([v]), vmax)[0])
            dl.add_line(imgui.ImVec2(x, y1), imgui.ImVec2(x, y1 + 4), white)
            text = images.fmt_tick(v)
            dl.add_text(imgui.ImVec2(x - 3 * len(text), y1 + 4), white, text)
        dl.add_text(imgui.ImVec2(x0, y0 - 16), white, label)

    def release(self) -> None:
        try:
            self.renderer.shutdown()
        except Exception:
            pass
