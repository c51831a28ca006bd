"""raster: its paper's figures and prose beside a benchmark run's, for the report
(report_notes, app.report.notes)."""
from __future__ import annotations

import copy
from functools import lru_cache

from . import CLUSTER_BOUNDED, CONTENTION_SCENE, VARIANTS, resolution
from .replay import cull_figures


def report_notes(technique, rows):
    return _notes(technique, rows)


SLIDES_TILE = {0: "1.44 ms (100%)", 1: "0.27 ms (18%)", 2: "0.36 ms (25%)", 3: "0.10 ms (7%)"}
SLIDES_TILE_MS = {0: 1.44, 1: 0.27, 2: 0.36, 3: 0.10}
SLIDES_SIZE = (1920, 1080)           # their 240 x 135 tiles of 8 x 8
MODEL_GPU = "ps4"                    # the slides' GPU in app/model/cost.py


def contention_figures(technique, size=SLIDES_SIZE) -> dict[int, dict]:
    """Per raster_variant, the contention scene at `size` (its default lights, frame 0): the
    stats twin's atomics and fragments, the tile grid, and the culling passes modelled on
    the slides' PS4.  Counters and model only, no timing (the report rebuilds to the same
    text from the same results); the shading passes skip their light loops (CELLS_ONLY).
    Made once a process (four 1920x1080 frames, ~3 s on llvmpipe: every report write)."""
    return copy.deepcopy(_contention_figures(technique, tuple(size)))


@lru_cache(maxsize=4)
def _contention_figures(technique, size) -> dict[int, dict]:
    from scenes import load_scene
    from ...model import cost, counts, waves
    from ...pipeline.renderer import Renderer
    gpu = cost.BY_KEY[MODEL_GPU]
    out = {}
    scene = load_scene(CONTENTION_SCENE)
    with Renderer(scene, tuple(size)) as r:
        for v in range(len(VARIANTS)):
            opts = technique.resolve_options({"raster_variant": v})
            res = r.render(technique, 0, opts, defines={"CELLS_ONLY": 1})
            frame = waves.frame_data(r, res, opts)
            figs = cull_figures(technique, frame, gpu.wave)
            counts.attach(figs, frame.programs)        # each pass's counted instructions
            st = res.meta["stats"]
            out[v] = {"atomics": int(st["raster_atomics"]), "fragments": int(st["raster_fragments"]),
                      "model_ms": sum(cost.pass_ms(f, gpu) for f in figs.values()),
                      "tiles": (res.build.grid.tiles_x, res.build.grid.tiles_y),
                      "lights": len(scene.lights), "size": tuple(size)}
    return out


def _share(a, b) -> str:
    return f"{a / b:.0%}" if b else "-"


def _variant_table(technique, study, measured=()) -> list[str]:
    """The slides' tile rasterizer table beside the contention scene's counters (rendered
    here at the slides' resolution), the variant study's rows, and the contention scene's
    own study rows (`measured`: the benchmark's "raster_variant@contention")."""
    import json
    from ...pipeline import gl
    by = {int(r["raster_variant"]): r for r in study}
    there = {int(r["raster_variant"]): r for r in measured}
    r0 = study[0]
    try:
        con = contention_figures(technique)
    except Exception as exc:                 # no GL context where the report is rebuilt
        con = {}
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    atomics = {v: json.loads(r["stats"]).get("raster_atomics") if r.get("stats") else None
               for v, r in by.items()}
    base_ms = float(by[0]["gpu_cull_ms"]) if 0 in by else 0.0
    text = []
    if con:
        tx, ty = con[0]["tiles"]
        w, h = con[0]["size"]
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside the {CONTENTION_SCENE} scene (three lights holding the whole hall and "
                 f"{con[0]['lights'] - 3} small ones, {w}x{h}: {tx}x{ty} tiles; the "
                 f"stats twin's atomics, rendered for this report, and the culling passes (the "
                 f"depth fill included) "
                 f"modelled on the PS4, whose model has no atomic contention) and this run's "
                 f"variant study ({r0['scene']}, {int(r0['lights'])} lights; culling passes with "
                 f"the depth fill measured here, median: on a software rasterizer MSAA is "
                 f"per-sample work and atomics are cheap, so only the atomic counts carry over):",
                 "", f"| variant | slides | {CONTENTION_SCENE}: atomics | of atomic | modelled PS4 "
                 + (f"| {CONTENTION_SCENE}: measured here, {resolution(measured[0])} | of atomic "
                    if there else "")
                 + f"| {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|" + ("---|---|" if there else "") + "---|---|---|---|"]
    else:
        text += [f"The slides' tile rasterizer table (\"3 x full screen lights - 240x135 - (PS4)\") "
                 f"beside this run's variant study ({r0['scene']}, {int(r0['lights'])} lights; "
                 f"culling passes with the depth fill, median; only the atomic counts carry over "
                 f"from a software rasterizer); the {CONTENTION_SCENE} scene's counters need a GL "
                 f"context, none here ({why}):", "",
                 f"| variant | slides | {r0['scene']}: measured | of atomic | atomics | of atomic |",
                 "|---|---|---|---|---|---|"]
    for v in range(len(VARIANTS)):
        r = by.get(v)
        cells = [VARIANTS[v], SLIDES_TILE[v]]
        if con:
            c = con[v]
            cells += [f"{c['atomics']:,}", _share(c["atomics"], con[0]["atomics"]),
                      f"{c['model_ms']:.3g} ms"]
            if there:
                m = there.get(v)
                cells += ([f"{float(m['gpu_cull_ms']):.3g} ms ({float(m['gpu_cull_min_ms']):.3g}-"
                           f"{float(m['gpu_cull_max_ms']):.3g})",
                           _share(float(m["gpu_cull_ms"]), float(there[0]["gpu_cull_ms"]))]
                          if m is not None and 0 in there else ["-", "-"])
        if r is None:
            cells += ["-"] * 4
        else:
            cull = float(r["gpu_cull_ms"])
            a, a0 = atomics.get(v), atomics.get(0)
            cells += [f"{cull:.3g} ms", _share(cull, base_ms), f"{a:,}" if a is not None else "-",
                      _share(a, a0) if a is not None and a0 else "-"]
        text.append("| " + " | ".join(cells) + " |")
    if con:
        sub = gl.limits().subgroup_size
        plain = con[0]
        text.append(
            f"\nIn the {CONTENTION_SCENE} scene every pixel marks three lights, so each tile's "
            f"pixels issue their atomics on the same words: compaction leaves "
            f"{_share(con[2]['atomics'], plain['atomics'])} of the plain rasterizer's "
            f"{plain['atomics']:,} atomics (on this driver's "
            f"{f'{sub}-lane ' if sub else ''}subgroups; a 64-lane wave merges more), MSAA "
            f"{_share(con[1]['atomics'], plain['atomics'])}, both "
            f"{_share(con[3]['atomics'], plain['atomics'])}, against the slides' times 25%, 18% "
            f"and 7%.  The model's PS4 culling time for the plain rasterizer, "
            f"{plain['model_ms']:.3g} ms, is {SLIDES_TILE_MS[0] / plain['model_ms']:.2g}x below "
            f"the slides' 1.44 ms: the model counts an atomic as one memory access, and their "
            f"contention is what compaction removes.")
    return text


def _cluster_text(study) -> list[str]:
    """Cluster against tile waste, with and without the depth bound (the `cluster` study)."""
    import json
    by = {int(r["cluster"]): r for r in study}
    if 0 not in by or not ({1, 2} & set(by)):
        return []
    st = {v: json.loads(r["stats"]) if r.get("stats") else {} for v, r in by.items()}
    t = by[0]
    tile = st[0].get("bit_tile_used", "?")
    parts = []
    for v in (1, 2):
        if v in by:
            r = by[v]
            parts.append(f"{float(r['evaluated_pp']):.3g} lights a pixel "
                         f"{'with' if v == CLUSTER_BOUNDED else 'without'} the depth bound "
                         f"(waste {float(r['waste']):.3g}x the exact lights)")
    text = [f"\nThe cluster rasterizer against the tiles (the cluster study, {t['scene']}, "
            f"{int(t['lights'])} lights): tiles evaluate {float(t['evaluated_pp']):.3g} lights a "
            f"pixel (waste {float(t['waste']):.3g}x), clusters {' and '.join(parts)}."]
    if 1 in by and 2 in by:
        b, u = st[1], st[2]
        same = float(by[1]["evaluated_pp"]) == float(by[2]["evaluated_pp"])
        text.append(
            f"The bound {'leaves the evaluations as they are' if same else 'changes the evaluations'}"
            f" (a pixel reads only the cluster of its own depth's slice, which lies within its "
            f"tile's depth range) and saves marking: {b.get('raster_marks', '-')} (cluster, light) "
            f"marks against {u.get('raster_marks', '-')}, {b.get('raster_atomics', '-')} atomics "
            f"against {u.get('raster_atomics', '-')}, culling {float(by[1]['gpu_cull_ms']):.3g} ms "
            f"against {float(by[2]['gpu_cull_ms']):.3g} ms (the bound's own depth pass included).")
    ctile = st.get(1, st.get(2, {})).get("bit_tile_used", "?")
    text.append(f"What the clusters waste would be their size on screen: {ctile} px clusters "
                f"against {tile} px tiles, each marked wherever a light's volume passes through "
                f"it, where a tile is marked only by a lit surface pixel of its own (argued here; "
                f"the --full preset's cluster_tile sweep measures it).")
    return [" ".join(text)]


def _cluster_tile_text(rows) -> list[str]:
    """The paper_cluster_tile sweep (with the cluster table's atomic row, and the rasterized
    tiles of the optimization table beside it): lights evaluated a pixel against the
    clusters' size."""
    import json
    from ...results import PAPER_PREFIX
    sweep = [r for r in rows if r.get("study") == PAPER_PREFIX + "cluster_tile" or (
        r.get("study") == PAPER_PREFIX + "cluster_raster" and int(float(r["raster_variant"])) == 0)]
    if len(sweep) < 2:
        return []
    px = lambda r: int(json.loads(r.get("stats") or "{}").get("bit_tile_used", 0))
    sweep.sort(key=px)
    f = lambda r, k: float(r[k])
    cells = [f"{px(r)} px {f(r, 'evaluated_pp'):.3g} lights a pixel (waste {f(r, 'waste'):.3g}x, "
             f"modelled PS4 culling {f(r, 'model_ps4_cull_ms'):.3g} + shading "
             f"{f(r, 'model_ps4_shade_ms'):.3g} ms)" for r in sweep]
    tiles = {int(float(r["zbin_variant"])): r for r in rows
             if r.get("study") == PAPER_PREFIX + "zbin_table" and r.get("technique") == "raster"}
    waste = [f(r, "waste") for r in sweep]
    falls = all(a <= b for a, b in zip(waste, waste[1:]))
    r0 = sweep[0]
    text = (f"\nThe cluster rasterizer's clusters swept ({r0['scene']}, {int(float(r0['lights']))} "
            f"lights, {int(float(r0['width']))}x{int(float(r0['height']))}, "
            f"{int(float(r0['cluster_slices']))} slices, atomic): " + "; ".join(cells) + ".  ")
    if 0 in tiles:
        t = tiles[0]
        text += (f"The rasterized 8-px tiles (base tile, no z-bins) evaluate "
                 f"{f(t, 'evaluated_pp'):.3g} (waste {f(t, 'waste'):.3g}x).  ")
    text += ("The waste falls as the clusters shrink: it is their size on screen, as argued "
             "above." if falls else "The waste does not fall steadily as the clusters shrink: "
             "their size on screen is not all of it.")
    return [text]


def _notes(technique, rows) -> tuple[str, str]:
    import json
    text = []
    study = [r for r in rows if r.get("study") == "raster_variant"]
    if study:
        text += _variant_table(technique, study, [r for r in rows if r.get("study") ==
                                                  f"raster_variant@{CONTENTION_SCENE}"])
    text += _cluster_text([r for r in rows if r.get("study") == "cluster"])
    text += _cluster_tile_text(rows)
    path = [r for r in rows if r.get("study") == "path"]
    st = [json.loads(r["stats"]) for r in path if r.get("stats")]
    if st:
        vis = sum(s.get("visible_lights", 0) for s in st)
        un = sum(s.get("unmarked_lights", 0) for s in st)
        occ = sum(s.get("occluded_lights", 0) for s in st)
        text.append(f"\nAlong the camera paths, {un} of {vis} visible lights marked no tile "
                    f"(their volume reaches no visible surface); {occ} of them a per-tile depth "
                    f"bounds test would still have kept: occlusion alone removed them.")
    return "what the slides measure", "\n".join(text)
