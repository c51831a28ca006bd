"""The HUD: its text (from the frame's figures, no GL) and the texture the text is drawn
into with PIL (blitted by the hud pass, app.window.passes), and the window title."""
from __future__ import annotations

import math

HELP = "1-9 technique  V view  WASD/QE+drag fly  P path  R reset  +/- lights  K shot  H hud"


def hud_lines(f: dict, *, position: str, role: str, software: bool, playing: bool,
              options: str, note: str | None, message: str = "") -> list[str]:
    """The HUD's lines for the figures `f` of a frame (app.window.app: _figures)."""
    cpu, gpu, setup = f["cpu_ms"], f["gpu_ms"], f.get("setup_ms") or {}
    wall = " (wall clock: software GL)" if software else ""
    tag = f" [{role}]" if role != "technique" else ""
    lines = [
        f"{f['technique']}{tag} ({position})   view: {f['view']}   "
        f"{f['size'][0]}x{f['size'][1]}" + ("   path" if playing else ""),
        f"lights {f['lights']}   visible {f['visible_lights']}   "
        f"evaluated/px {f['evaluated_per_pixel']:.2f}   exact/px {f['exact_per_pixel']:.2f}",
        f"CPU {sum(cpu.values()):.1f} ms: " + "  ".join(f"{k} {v:.1f}" for k, v in cpu.items()),
        f"GPU {sum(gpu.values()):.1f} ms{wall}: " + "  ".join(f"{k} {v:.1f}" for k, v in gpu.items()),
    ]
    if setup:
        lines.append(f"set-up, untimed {sum(setup.values()):.1f} ms: "
                     + "  ".join(f"{k} {v:.1f}" for k, v in setup.items()))
    lines.append(options)
    if note:
        lines.append(note)
    lines.append(HELP)
    if message:
        lines.append(message)
    return lines


def title(f: dict) -> str:
    return (f"many-light lab: {f['technique']} | {f['view']} | {f['visible_lights']}/"
            f"{f['lights']} lights | {f['evaluated_per_pixel']:.2f} eval/px | "
            f"CPU {sum(f['cpu_ms'].values()):.1f} ms | GPU {sum(f['gpu_ms'].values()):.1f} ms")


class HudTexture:
    """The HUD text as an RGBA texture (row 0 = top, as PIL draws it; present.frag flips),
    sized to the text and to the frame, remade only when its size changes."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.texture = None
        self._fonts: dict = {}

    def _font(self, px: int):
        from PIL import ImageFont
        font = self._fonts.get(px)
        if font is None:
            try:
                font = ImageFont.load_default(size=px)
            except TypeError:      # Pillow < 10.1: bitmap font only
                font = ImageFont.load_default()
            self._fonts[px] = font
        return font

    def draw(self, lines: list[str], frame_size) -> None:
        import moderngl
        from PIL import Image, ImageDraw
        w, h = frame_size
        px = max(9, min(16, h // 30))
        font = self._font(px)
        line_h = px + 3
        lines = lines[:max(1, (h - 4) // line_h)]
        tw = min(w, 8 + max(int(math.ceil(font.getlength(l))) for l in lines))
        th = min(h, 6 + line_h * len(lines))
        img = Image.new("RGBA", (tw, th), (0, 0, 0, 150))
        d = ImageDraw.Draw(img)
        for i, line in enumerate(lines):
            d.text((4, 3 + i * line_h), line, font=font, fill=(255, 255, 255, 255))
        if self.texture is None or self.texture.size != (tw, th):
            self.release()
            self.texture = self.ctx.texture((tw, th), 4)
            self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.write(img.tobytes())

    def release(self) -> None:
        if self.texture is not None:
            self.texture.release()
            self.texture = None
