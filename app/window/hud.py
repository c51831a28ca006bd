"""The HUD's text (from the frame's figures; no GL) and the window title.  app.window.ui
draws it in an imgui overlay at the top left."""
from __future__ import annotations

import math

from .keys import KEYS

HELP = "  ".join(f"{k} {word}" for k, word, _ in KEYS if k != "Esc")


def exposure_text(exposure: float, auto: bool, ambient: float) -> str:
    ev = math.log2(exposure) if exposure > 0 else 0.0
    return (f"exposure {'auto ' if auto else ''}x{exposure:.3g} (EV {ev:+.1f})   "
            f"ambient {ambient:g} (display only)")


def hud_lines(f: dict, *, position: str, role: str, software: bool, playing: bool,
              options: str, note: str | None, message: str = "", exposure: str = "",
              status: str = "", warning: str = "") -> list[str]:
    """The HUD's lines for the figures `f` of a frame (app.window.app: _figures)."""
    cpu, gpu, setup = f["cpu_ms"], f["gpu_ms"], f.get("setup_ms") or {}
    wall = " (wall clock: software GL)" if software else ""
    tag = f" [{role}]" if role != "technique" else ""
    lines = [
        f"{f['technique']}{tag} ({position})   view: {f['view']}   "
        f"{f['size'][0]}x{f['size'][1]}" + ("   path" if playing else "") + (f"   {status}" if status else ""),
        f"lights {f['lights']}   visible {f['visible_lights']}   "
        f"evaluated/px {f['evaluated_per_pixel']:.2f}   exact/px {f['exact_per_pixel']:.2f}",
        f"CPU {sum(cpu.values()):.1f} ms: " + "  ".join(f"{k} {v:.1f}" for k, v in cpu.items()),
        f"GPU {sum(gpu.values()):.1f} ms{wall}: " + "  ".join(f"{k} {v:.1f}" for k, v in gpu.items()),
    ]
    if f.get("model"):
        lines.append(f["model"])
    if setup:
        lines.append(f"set-up, untimed {sum(setup.values()):.1f} ms: "
                     + "  ".join(f"{k} {v:.1f}" for k, v in setup.items()))
    lines.append(options)
    if exposure:
        lines.append(exposure)
    if note:
        lines.append(note)
    lines.append(HELP)
    if warning:
        lines.append(warning)
    if message:
        lines.append(message)
    return lines


def title(f: dict) -> str:
    return (f"many-light lab: {f['technique']} | {f['view']} | {f['visible_lights']}/"
            f"{f['lights']} lights | {f['evaluated_per_pixel']:.2f} eval/px | "
            f"CPU {sum(f['cpu_ms'].values()):.1f} ms | GPU {sum(f['gpu_ms'].values()):.1f} ms")
