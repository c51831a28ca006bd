"""zbin: its paper's figures and prose beside a benchmark run's, for the report
(report_notes, app.report.notes)."""
from __future__ import annotations

import numpy as np

from ..bit_arrays import VARIANTS


def report_notes(technique, rows):
    """The slides' memory and optimization tables beside this run's (app/report/notes.py)."""
    return _notes(technique, rows)


SLIDES_MEMORY = (("tile bit arrays, 8 px (240 x 135)", "1,036 KB"),
                 ("+ z-bins (8096)", "+ 32 KB"),
                 ("clustered bit arrays (60 x 32 x 18)", "1,106 KB"))
SLIDES_TIME = {0: "5.7 ms (100%)", 1: "5.2 ms (91%)", 2: "5.1 ms (88%)", 3: "4.6 ms (80%)"}


def _frame_1080p(n: int):
    """n small lights spread in front of a 1920x1080 camera: the slides' memory table input."""
    from cpu_prep.camera import frame_camera
    from scenes.model import Camera, make_lights
    from ...pipeline.passes import FrameInput
    cam = frame_camera(Camera((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), far=300.0), 1920, 1080)
    k = np.arange(n, dtype=np.float64)
    depth = 10.0 + 1.0 * k                 # all in front of the far plane: every light visible
    L = make_lights(n)
    L["position"] = np.column_stack([np.sin(k) * 0.5 * depth * cam.tan_half_x,
                                     np.cos(1.7 * k) * 0.5 * depth * cam.tan_half_y, -depth])
    L["radius"] = 1.0
    return FrameInput(L, cam, 600.0)


def _notes(technique, rows) -> tuple[str, list[str]]:
    import json
    spread = lambda r: (float(r["gpu_shade_ms"]), float(r["gpu_shade_min_ms"]), float(r["gpu_shade_max_ms"]))
    text = []
    b = technique.build(_frame_1080p(256), None)
    clustered = 60 * 32 * 18 * (256 // 8)
    text += ["The slides' memory table (1080p, a 256-light bit array) beside this technique's "
             "own build at 1920x1080 with 256 visible lights:", "",
             "| structure | slides | this lab |", "|---|---|---|",
             f"| {SLIDES_MEMORY[0][0]} | {SLIDES_MEMORY[0][1]} | {b.buffers['tile_bits'].nbytes:,} B "
             f"(its buffer's bytes) |",
             f"| {SLIDES_MEMORY[1][0]} | {SLIDES_MEMORY[1][1]} | + {b.buffers['zbins'].nbytes:,} B "
             f"(its buffer's bytes) |",
             f"| {SLIDES_MEMORY[2][0]} | {SLIDES_MEMORY[2][1]} | {clustered:,} B (arithmetic: 60 x "
             f"32 x 18 cells x 32 B; this lab's clustered keeps index lists, no bit arrays) |", ""]
    path = [r for r in rows if r["study"] == "path" and r["technique"] == technique.name]
    for scene in dict.fromkeys(r["scene"] for r in path):
        st = [json.loads(r["stats"]) for r in path if r["scene"] == scene and r.get("stats")]
        merged = sum(s.get("wave_iterations", 0) for s in st)
        longest = sum(s.get("lane_max_iterations", 0) for s in st)
        if merged and longest:
            text.append(f"\n{scene} (the default variant, every path frame): the scalarized loop "
                        f"runs {merged / longest:.3f}x the iterations of the waves' longest "
                        f"per-lane loop, so a scalarized iteration must cost under "
                        f"{longest / merged:.0%} of a per-lane one to win.  (The slides' 72% for "
                        f"the flat scalarized F+ is the whole shader's cost against the base, and "
                        f"includes its occupancy going from 5 to 8 waves as its registers fall "
                        f"from 56 to 32 VGPRs: not a cost per iteration.)")
    study = [r for r in rows if r["study"] == "zbin_variant"]
    by = {(r["technique"], int(r["zbin_variant"])): r for r in study}
    # the slides' own pipeline first (rasterized tiles), then this technique's CPU tiles
    techs = sorted(dict.fromkeys(r["technique"] for r in study), key=lambda t: t == technique.name)
    if study:
        r0 = study[0]
        head = " | ".join(f"{t}: ms (min-max), of its base, evaluated/px" for t in techs)
        text += ["", f"The slides' optimization table (Zombies opening scene, PS4 1080p, the opaque "
                 f"pass) beside this run's variant study ({r0['scene']}, {int(r0['lights'])} lights, "
                 f"shading pass median on this machine's renderer): the slides' own pipeline, "
                 f"rasterized tiles (raster), then zbin's CPU tiles"
                 f"{' tested against each tile depth' if any(r.get('tile_depth') == 1 for r in study) else ''}:",
                 "", f"| variant | slides | {head} |", "|---|---|" + "---|" * len(techs)]
        for v in range(4):
            cells = []
            for t in techs:
                r, base = by.get((t, v)), by.get((t, 0))
                if r is None:
                    cells.append("-")
                    continue
                med, lo, hi = spread(r)
                ratio = f"{med / spread(base)[0]:.0%}" if base else "-"
                cells.append(f"{med:.3g} ({lo:.3g}-{hi:.3g}), {ratio}, {r['evaluated_pp']:.3g}")
            text.append(f"| {VARIANTS[v]} | {SLIDES_TIME[v]} | " + " | ".join(cells) + " |")
        for t in techs:
            if (t, 0) in by and (t, 1) in by:
                (a, a_lo, _), (z, _, z_hi) = spread(by[(t, 0)]), spread(by[(t, 1)])
                saving = 1.0 - z / a if a > 0 else 0.0
                sure = "beyond the measured spread" if z_hi < a_lo else "within the measured spread"
                text.append(f"\n{t}: z-binning saves {saving:.0%} of the base tile's shading time "
                            f"here, {sure} (the slides: 15% on the hangar fire scene, 9% on the "
                            f"zombies scene); it evaluates {by[(t, 1)]['evaluated_pp']:.3g} lights "
                            f"a pixel instead of {by[(t, 0)]['evaluated_pp']:.3g}.")
    depth = {bool(r["tile_depth"]): r for r in rows if r["study"] == "tile_depth"}
    if True in depth and False in depth:
        on, off = depth[True], depth[False]
        kept = json.loads(on.get("stats") or "{}").get("depth_kept_share")
        text.append(f"\nThe tile depth test ({on['scene']}, {int(on['lights'])} lights, the default "
                    f"variant) keeps {kept:.0%} of the CPU tiles' bits; lights evaluated a pixel "
                    f"{off['evaluated_pp']:.3g} -> {on['evaluated_pp']:.3g}; shading "
                    f"{spread(off)[0]:.3g} -> {spread(on)[0]:.3g} ms, the test itself "
                    f"{float(on.get('gpu_cull_ms') or 0):.3g} ms." if kept is not None else "")
    return "what the slides measure", "\n".join(text)
