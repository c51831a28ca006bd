"""The figures/HUD model: what a frame measured and what the UI shows of it.  No GL.

    frame_sums     a frame's sums (view_stats, view_extra) per covered pixel
    frame_figures  the frame's figures: the HUD's, the title's and the --json line's
    heat_top       the top of the heat scale (app.images.heat_top over the halves shown)
    heat_scale     the colour bar's (top, label), or None
    UIModel        everything app.window.ui draws: it reads this, never the window
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .. import images


def _ms(d: dict) -> dict:
    return {k: round(float(v), 3) for k, v in d.items()}


def frame_sums(stats, extra) -> dict:
    """Lights evaluated and exact per covered pixel, and the largest of each."""
    covered = int(stats["covered"])
    total = lambda lo, hi: float(stats[lo]) + float(stats[hi]) * 2.0**32
    per_pixel = lambda lo, hi: total(lo, hi) / covered if covered else 0.0
    return {"evaluated_per_pixel": per_pixel("evaluated_lo", "evaluated_hi"),
            "exact_per_pixel": per_pixel("exact_lo", "exact_hi"),
            "max_evaluated": int(stats["max_evaluated"]), "max_exact": extra["max_exact"],
            "covered": covered}


def split_figures(technique, meta, stats, extra) -> dict:
    """The split view's second technique: its sums and timings."""
    sums = frame_sums(stats, extra)
    del sums["covered"]
    return {"technique": technique.name, **sums, "cpu_ms": _ms(meta["cpu_ms"]),
            "gpu_ms": _ms(meta["gpu_ms"])}


def heat_top(state, sums: dict, split: dict | None) -> float:
    """The heat scale's top: the panel's fixed one, else the largest count of the halves
    shown (both halves of the split view on one scale)."""
    key = "max_evaluated" if state.heat_of == "evaluated" else "max_exact"
    largest = max([sums[key]] + ([split[key]] if split is not None else []))
    return images.heat_top(largest, state.heat_max)


def frame_figures(c, state, *, lights: int, size, recorder, cam, reference: str) -> dict:
    """The frame's figures (c: compose.Composed)."""
    m = c.result.meta
    _, ignored = state.options.for_technique(state.tech)
    return {
        "technique": m["technique"], "view": state.view, "lights": lights,
        "visible_lights": int(m["stats"].get("visible_lights", len(c.result.build.lights.gpu))),
        **c.sums, "lit": c.extra["lit"],
        "cpu_ms": _ms(m["cpu_ms"]), "cpu_threads": m["cpu_threads"], "gpu_ms": _ms(m["gpu_ms"]),
        "setup_ms": _ms(m["setup_ms"]), "options": m["options"], "ignored_options": list(ignored),
        # a cap policy's frame differs from brute on purpose: the HUD says by how much
        "capped": ({"policy": m["stats"]["cap_policy"], "lights": int(m["stats"]["capped_lights"])}
                   if "cap_policy" in m["stats"] else None),
        "grid": c.overlay.as_dict(),
        "exposure": round(float(c.exposure), 6), "exposure_auto": state.exposure_auto,
        "ambient": state.ambient, "heat_max": heat_top(state, c.sums, c.split),
        "heat_of": state.heat_of, "heat_overlay": state.heat_overlay,
        "differ": c.extra["differ"] if c.ref_valid else None,
        "reference": reference if state.view == "diff" else None,
        "split": c.split, "inspect": c.inspection.as_dict() if c.inspection else None,
        "size": list(size), "playing": recorder.playing, "path_frame": recorder.frame,
        "recording": len(recorder.recording) if recorder.recording is not None else None,
        "camera": [round(float(v), 3) for v in cam.position],
        "target": [round(float(v), 3) for v in cam.target],
    }


def heat_scale(f: dict, view_shown: str, state, map_shown) -> tuple[float, str] | None:
    """(top, label) of the colour bar when the view shows a heat map or a technique's map
    (both log2(1 + n) on turbo), else None."""
    if not f:
        return None
    if view_shown in ("maps", "froxels", "layers"):
        name, label, top = map_shown
        return (float(top), f"{name}: {label}, log2(1 + n)") if name else None
    if not (view_shown == "heat" or (view_shown == "split" and state.split_view == "heat")):
        return None
    what = "lights evaluated" if f["heat_of"] == "evaluated" else "exact lights"
    fixed = "fixed" if state.heat_max > 0 else "frame max"
    return f["heat_max"], f"{what} / pixel, log2(1 + n); top {f['heat_max']:g} ({fixed})"


@dataclass
class UIModel:
    """What the UI draws this frame, read from the window's parts by LabWindow.ui_model."""
    hud: bool                                   # the HUD (and the panel, the colour bar) at all
    panel: bool
    hud_lines: list[str] = field(default_factory=list)     # "!..." lines are warnings
    controls: list = field(default_factory=list)           # panel.Control, in section order
    section_lines: dict = field(default_factory=dict)      # section -> text lines under it
    timers: list = field(default_factory=list)             # (name, median, min, n, history | None)
    heat_scale: tuple[float, str] | None = None
    keys: list = field(default_factory=list)               # (key label, what it does)
    legend: list = field(default_factory=list)             # the variants view's (variant_view.Entry)
    frame_dt: float = 1 / 60
