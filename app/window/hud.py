"""The HUD's text (from the frame's figures; no GL), the panel's text sections and the
window title.  app.window.ui draws them (the HUD in an imgui overlay at the top left)."""
from __future__ import annotations

import math

from .keys import help_line
from .probe import SLOW_MS, duration
from .fog_view import feature_lines
from .views import WINDOW_VIEWS, view_note

HELP = help_line()


def exposure_text(exposure: float, auto: bool, ambient: float) -> str:
    ev = math.log2(exposure) if exposure > 0 else 0.0
    return (f"exposure {'auto ' if auto else ''}x{exposure:.3g} (EV {ev:+.1f})   "
            f"ambient {ambient:g} (display only)")


def threads_text(n: int | None) -> str:
    """' (2 threads)' beside the CPU stage's time; nothing on one thread or unknown."""
    return f" ({n} threads)" if n and n > 1 else ""


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
        f"evaluated/px {f['evaluated_per_pixel']:.2f}   exact/px {f['exact_per_pixel']:.2f}"
        + capped_text(f.get("capped")),
        f"CPU {sum(cpu.values()):.1f} ms{threads_text(f.get('cpu_threads'))}: " + "  ".join(f"{k} {v:.1f}" for k, v in cpu.items()),
        f"GPU {sum(gpu.values()):.1f} ms{wall}: " + "  ".join(f"{k} {v:.1f}" for k, v in gpu.items()),
    ]
    scale = scale_text(f)
    if scale:
        lines.insert(1, scale)
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


def scale_text(f: dict) -> str:
    """The HUD's line of the frame's scale (dynamic resolution, app.window.scale): 'moving:
    scale 50% (480x270), 9.6 fps (target 10); figures below: full size, at rest' on a reduced
    frame, 'scale 100%' on a full-size one; '' when it is off (--target-fps 0) or the
    figures have none."""
    scale, target, fixed = f.get("scale"), f.get("target_fps") or 0.0, f.get("move_scale")
    if scale is None or (target <= 0.0 and fixed is None):
        return ""
    if scale >= 1.0:
        return "scale 100%"
    w, h = f["render_size"]
    how = "--move-scale" if fixed is not None else f"target {target:g}"
    fps = f", {1000.0 / f['frame_ms']:.1f} fps" if f.get("frame_ms") else ""
    return f"moving: scale {scale:.0%} ({w}x{h}){fps} ({how}); figures below: full size, at rest"


def capped_text(capped) -> str:
    """'   capped: 496 lights dropped by urp-16 (not exact, on purpose)', or '' without a cap."""
    if not capped:
        return ""
    return f"   capped: {capped['lights']} lights dropped by {capped['policy']} (not exact, on purpose)"


def title(f: dict) -> str:
    return (f"many-light lab: {f['technique']} | {f['view']} | {f['visible_lights']}/"
            f"{f['lights']} lights | {f['evaluated_per_pixel']:.2f} eval/px | "
            f"CPU {sum(f['cpu_ms'].values()):.1f} ms | GPU {sum(f['gpu_ms'].values()):.1f} ms")


def slow_warning(technique: str, predicted_ms) -> str:
    if predicted_ms is None or predicted_ms <= SLOW_MS:
        return ""
    return f"slow: {technique} takes about {predicted_ms / 1000:.1f} s a frame here"


def window_hud(f: dict, state, *, message: str, warning: str, predicted_ms, status: list[str],
               playing: bool, software: bool, map_shown, overlay, reference: str,
               inspection) -> list[str]:
    """The window's HUD: hud_lines of the figures `f`, the view's note, the split's line,
    the inspection; a warning line starts with '!' (the UI colours it)."""
    s = state
    moving = bool(f) and f.get("scale", 1.0) < 1.0       # a reduced frame is not the slow one
    warning = warning or ("" if moving else slow_warning(s.technique, predicted_ms))
    warning = "!" + warning if warning else ""
    if not f:
        return [l for l in (warning, message) if l] or ["starting ..."]
    map_name, map_label, map_top = map_shown
    note = view_note(f["view"], s.technique, overlay, f["heat_max"], heat_of=f["heat_of"],
                     overlay_mode=f["heat_overlay"], reference=reference, differ=f["differ"],
                     split=s.split_with, split_view=s.split_view, map_name=map_name,
                     map_label=map_label, map_top=map_top)
    if f["view"] in WINDOW_VIEWS:
        note = f.get("scene_note") or note
    elif f["view"] == "heat" and f.get("transparent"):
        note += " (the opaque surface's; view layers: with its transparent layers)"
    names = list(s.registry)
    lines = hud_lines(f, position=f"{names.index(s.technique) + 1}/{len(names)}", role=s.tech.role,
                      software=software, playing=playing, options=s.options.hud_line(s.tech),
                      note=note, message=message,
                      exposure=exposure_text(f["exposure"], s.exposure_auto, s.ambient),
                      status="   ".join(status), warning=warning)
    more = stereo_lines(f.get("stereo")) + feature_lines(f)
    if more:
        at = next((i + 1 for i, l in enumerate(lines) if l.startswith("GPU ")), len(lines))
        lines[at:at] = more
    if s.panel:
        lines = [l for l in lines if l != HELP]     # the panel lists the keys
    if s.inspect:
        lines += (["inspect: " + l for l in inspection.lines(most=10)] if inspection
                  else ["inspect: move the cursor over the image"])
    if f.get("split"):
        sp = f["split"]
        lines.insert(2, f"right: {sp['technique']}   evaluated/px {sp['evaluated_per_pixel']:.2f}   "
                        f"GPU {sum(sp['gpu_ms'].values()):.1f} ms   CPU {sum(sp['cpu_ms'].values()):.1f} ms")
    return lines


def stereo_lines(st: dict | None) -> list[str]:
    """The HUD's lines of a stereo frame (stereo_view.py): the way, then each eye's figures."""
    if not st:
        return []
    shared = (f"; shared CPU stage ({st['share']}) {sum(st['shared_cpu_ms'].values()):.1f} ms"
              if st.get("shared_cpu_ms") else "")
    out = [f"stereo {st['way']}, eyes {st['separation']:g} m apart, each {st['eye_size'][0]}x"
           f"{st['eye_size'][1]} (B: mono); CPU and GPU above: both eyes summed{shared}"]
    for eye, e in st["eyes"].items():
        out.append(f"{eye}: visible {e['visible_lights']}   evaluated/px {e['evaluated_per_pixel']:.2f}   "
                   f"exact/px {e['exact_per_pixel']:.2f}   CPU {e['cpu_ms']:.1f} ms   GPU {e['gpu_ms']:.1f} ms")
    return out


def technique_lines(state, started: list[str], predicted_ms) -> list[str]:
    """The panel's technique section: its summary, how the start chose it (and what the
    probe skipped, a line each), its frame cost."""
    out = [f"{state.technique}: {state.tech.summary}"] + list(started)
    if predicted_ms is not None:
        out.append(f"about {duration(predicted_ms)} a frame here" + ("  (slow)" if predicted_ms > SLOW_MS else ""))
    return out


def inspect_lines(state, inspection) -> list[str]:
    if not state.inspect:
        return ["off (I): the light and the tile under the cursor"]
    if inspection is None:
        return ["move the cursor over the image"]
    return inspection.lines()
