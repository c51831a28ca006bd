"""Transparent layers against the opaque frame (app/pipeline/transparent.py): `DIR/transparent.csv`.

On frame 0 of each scene with transparent surfaces, every technique of the registry renders
the frame with its layers (the scene as it is) and the opaque-only frame (the same scene
with its transparent meshes dropped: the same G-buffer, lights and structure, no layer).
Each is rendered once untimed (compiles; read back: the counters of the opaque pixels and
of every layer's fragments, held to brute's frame with layers, and the opaque-only frame's
opaque pixels held to the layered frame's), then `repeat` interleaved rounds of timing
samples, one render of each frame a round.  A layered sample is the frame's timed passes
and, measured by this study around the same GL work with the renderer's own timer, the
layers' peel and their compositing (which the renderer runs untimed): so

    cpu_total_ms           the layered frame's CPU stage (+ _min / _max); no layer redoes it
    opaque_cpu_total_ms    the opaque-only frame's CPU stage
    extra_cpu_ms           layered minus opaque-only, a round's pair at a time (median, min, max)
    gpu_lighting_ms        the layered frame's timed GPU passes but the G-buffer: the peel,
                           every layer's passes of the technique, the compositing, the
                           opaque passes
    opaque_gpu_lighting_ms the opaque-only frame's
    layers_gpu_ms          the layers' own: peel + the technique's passes over every layer +
                           compositing (the extra GPU ms; + _min / _max)
    layer_bytes            bytes the technique's GPU passes write again over each layer (the
                           structure a technique that rebuilds per layer makes from the depth
                           it reads, a per-pixel scratch of a looked-up one; 0: none),
                           layer_bytes_total that times the layers used
    evaluated_pp, exact_pp, waste   per opaque pixel (lights evaluated, exact, their ratio)
    evaluated_pf, exact_pf, waste_layers   the same per layer fragment (every layer's)
    per_layer              JSON, a layer each: fragments, evaluated and exact per fragment,
                           pixels whose count or hash differ from brute's layer
    mismatch_count / mismatch_hash   opaque pixels that differ from brute's (0)
    layer_mismatch_count / layer_mismatch_hash   layer fragments that differ from brute's (0)
    opaque_differs         opaque pixels whose count or hash differ between the layered frame
                           and the opaque-only frame (0: the same opaque frame)
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
import json
from pathlib import Path
import sys

import numpy as np

from ..results import FRAME_PASS, stats
from . import measure
from .study import FileStudy, series_files, study_scene, write_series

CSV = "transparent.csv"        # read by app.report.transparent (not imported from there: GL)
LOOKED_UP, REBUILT = "looked up", "rebuilt per layer"

COLUMNS = ["study", "scene", "lights", "visible", "width", "height", "frame", "technique", "role",
           "serves", "rebuilt", "layers", "max_layers", "fragments", "opaque_pixels",
           "cpu_total_ms", "cpu_total_min_ms", "cpu_total_max_ms",
           "opaque_cpu_total_ms", "opaque_cpu_total_min_ms", "opaque_cpu_total_max_ms",
           "extra_cpu_ms", "extra_cpu_min_ms", "extra_cpu_max_ms",
           "gpu_lighting_ms", "gpu_lighting_min_ms", "gpu_lighting_max_ms",
           "opaque_gpu_lighting_ms", "opaque_gpu_lighting_min_ms", "opaque_gpu_lighting_max_ms",
           "layers_gpu_ms", "layers_gpu_min_ms", "layers_gpu_max_ms", "peel_ms", "composite_ms",
           "frame_cost_ms", "frame_cost_min_ms", "frame_cost_max_ms",
           "opaque_frame_cost_ms", "opaque_frame_cost_min_ms", "opaque_frame_cost_max_ms",
           "layer_setup_ms", "bytes_culling", "layer_bytes", "layer_bytes_total",
           "evaluated_pp", "exact_pp", "waste", "evaluated_pf", "exact_pf", "waste_layers",
           "per_layer", "samples", "mismatch_count", "mismatch_hash", "layer_mismatch_count",
           "layer_mismatch_hash", "opaque_differs"]
TEXT = ("serves", "rebuilt", "per_layer")      # text columns (app.report.transparent)


@dataclass(frozen=True)
class TransparentConfig:
    """The study's settings: frame 0 of each of `scenes` (scenes with transparent surfaces;
    () none) at `lights` lights and `size`, at most `layers` layers a pixel, `repeat` timing
    samples of each frame."""
    scenes: tuple[str, ...]
    lights: int
    size: tuple[int, int]
    repeat: int
    layers: int = 4
    seed: int = 0


def techniques() -> list:
    """Every technique of the registry, in its order (every one serves the layers)."""
    from ..techniques import REGISTRY
    return list(REGISTRY.values())


def serves(technique) -> tuple[str, str]:
    """(LOOKED_UP or REBUILT, what is rebuilt per layer: "" when looked up) from the
    technique's declaration (Technique.transparent)."""
    from ..techniques.base import TRANSPARENT_LOOKUP, TRANSPARENT_REBUILT
    text = technique.transparent
    if text == TRANSPARENT_LOOKUP:
        return LOOKED_UP, ""
    head, tail = TRANSPARENT_REBUILT.split("{what}")
    what = text[len(head):len(text) - len(tail)] if text.startswith(head) and text.endswith(tail) else text
    for end in (" are", " is"):
        what = what[:-len(end)] if what.endswith(end) else what
    return REBUILT, what


def opaque_only(scene):
    """The scene with its transparent meshes dropped (a copy; the scene is left as it was)."""
    out = copy.copy(scene)
    out.meshes = [m for m in scene.meshes if not m.transparent]
    return out


def layer_figures(res, ref) -> tuple[list[dict], dict]:
    """(a dict a layer used: fragments, evaluated_pf, exact_pf, mismatch; the figures over
    every layer's fragments) of a read-back frame against the reference's."""
    covered = res.depth_t > 0
    per = []
    for k in range(int(res.meta["transparent"]["layers"])):
        c = covered[k]
        n = int(c.sum())
        bad = int(((res.contrib_count_t[k] != ref.contrib_count_t[k]) |
                   (res.contrib_hash_t[k] != ref.contrib_hash_t[k])).sum())
        per.append({"layer": k, "fragments": n,
                    "evaluated_pf": round(float(res.evaluated_t[k][c].mean()) if n else 0.0, 4),
                    "exact_pf": round(float(res.contrib_count_t[k][c].mean()) if n else 0.0, 4),
                    "mismatch": bad})
    ev = res.evaluated_t[covered].astype(np.float64)
    ex = res.contrib_count_t[covered].astype(np.float64)
    return per, {
        "fragments": int(covered.sum()),
        "evaluated_pf": float(ev.mean()) if ev.size else 0.0,
        "exact_pf": float(ex.mean()) if ex.size else 0.0,
        "waste_layers": float(ev.sum() / ex.sum()) if ex.sum() > 0 else float("nan"),
        "layer_mismatch_count": int((res.contrib_count_t != ref.contrib_count_t).sum()),
        "layer_mismatch_hash": int((res.contrib_hash_t != ref.contrib_hash_t).sum()),
    }


def layer_bytes(res) -> int:
    """Bytes the frame's timed passes bound that no upload of the CPU stage holds: what the
    technique's GPU passes write, which the layers' run of its steps writes again."""
    uploads = set(res.build.buffers)
    return int(sum(v for k, v in res.meta["bytes"].items() if k not in uploads))


def layered_sample(meta: dict, peel_ms: float, composite_ms: float) -> dict:
    """A layered frame's timing sample: the G-buffer, the peel, every layer's passes, the
    compositing and then the opaque passes (the shading pass last, measure.split_gpu)."""
    gpu = {FRAME_PASS: meta["gpu_ms"].get(FRAME_PASS, 0.0), "transparent peel": peel_ms}
    gpu.update({f"transparent {k}": v for k, v in meta["transparent"]["gpu_ms"].items()})
    gpu["transparent composite"] = composite_ms
    gpu.update({k: v for k, v in meta["gpu_ms"].items() if k != FRAME_PASS})
    return {"cpu_ms": dict(meta["cpu_ms"]), "gpu_ms": gpu}


def timed_layers(renderer, timer) -> tuple[float, float]:
    """(peel ms, compositing ms) of the layers over the frame the renderer just rendered,
    timed by `timer` (a gl.PassTimer of the renderer's context, the renderer's own kind)
    around the same GL work."""
    layers = renderer.transparent
    camera = renderer.frame_input(0, 64).camera
    timer.run("peel", lambda: layers.peel(renderer, camera))
    timer.run("composite", lambda: layers.composite(renderer))
    ms = timer.take()
    return ms["peel"], ms["composite"]


def _prefixed(cells: dict, prefix: str) -> dict:
    keys = ("cpu_total", "gpu_lighting", "frame_cost")
    return {f"{prefix}{k}{s}_ms": cells[f"{k}{s}_ms"] for k in keys for s in ("", "_min", "_max")}


def run_scene(glass, opaque, c: TransparentConfig, log=None) -> list[dict]:
    """The rows of one scene's frame 0 (its layered and opaque-only renderers)."""
    from ..pipeline import gl
    from ..techniques import with_role
    log = log or sys.stderr
    timer = gl.PassTimer(glass.ctx)
    reference = with_role("reference")
    ref = glass.render(reference)
    rows = []
    for t in techniques():
        first = ref if t is reference else glass.render(t)      # compiles; read back
        alone = opaque.render(t)
        how, what = serves(t)
        per, figs = layer_figures(first, ref)
        layered, plain, extra = [], [], []
        for _ in range(c.repeat):                       # interleaved rounds
            res = glass.render(t, readback=False)
            layered.append(layered_sample(res.meta, *timed_layers(glass, timer)))
            plain += measure.samples_of(opaque.render(t, readback=False).meta)
            extra.append(sum(layered[-1]["cpu_ms"].values()) - sum(plain[-1]["cpu_ms"].values()))
        cells, ocells = measure.timing_cells(layered), measure.timing_cells(plain)
        own = [sum(v for k, v in s["gpu_ms"].items() if k.startswith("transparent "))
               for s in layered]
        fig = measure.figure_cells(first)
        n_layers = int(first.meta["transparent"]["layers"])
        row = dict(study="transparent", width=glass.size[0], height=glass.size[1], frame=0,
                   technique=t.name, role=t.role, serves=how, rebuilt=what, layers=n_layers,
                   max_layers=int(first.meta["transparent"]["max_layers"]),
                   opaque_pixels=int((first.depth > 0).sum()),
                   visible=int(first.meta["stats"].get("visible_lights", 0)),
                   samples=len(layered), evaluated_pp=fig["evaluated_pp"], exact_pp=fig["exact_pp"],
                   waste=fig["waste"], bytes_culling=fig["bytes_culling"],
                   layer_bytes=layer_bytes(first), per_layer=json.dumps(per),
                   layer_setup_ms=float(sum(first.meta["transparent"].get("setup_ms", {}).values())),
                   peel_ms=stats(s["gpu_ms"]["transparent peel"] for s in layered)[0],
                   composite_ms=stats(s["gpu_ms"]["transparent composite"] for s in layered)[0],
                   opaque_differs=int(((first.contrib_count != alone.contrib_count) |
                                       (first.contrib_hash != alone.contrib_hash)).sum()))
        row["layer_bytes_total"] = row["layer_bytes"] * n_layers
        row.update(figs)
        row.update(_prefixed(cells, ""))
        row.update(_prefixed(ocells, "opaque_"))
        row["extra_cpu_ms"], row["extra_cpu_min_ms"], row["extra_cpu_max_ms"] = stats(extra)
        row["layers_gpu_ms"], row["layers_gpu_min_ms"], row["layers_gpu_max_ms"] = stats(own)
        row["mismatch_count"] = int((first.contrib_count != ref.contrib_count).sum())
        row["mismatch_hash"] = int((first.contrib_hash != ref.contrib_hash).sum())
        rows.append(row)
        log.write(f"bench: transparent {t.name} ({how}): {n_layers} layers, {figs['fragments']} "
                  f"fragments, layers {row['layers_gpu_ms']:.2f} ms GPU over the opaque frame's "
                  f"{row['opaque_gpu_lighting_ms']:.2f}, layer mismatches "
                  f"{figs['layer_mismatch_count'] + figs['layer_mismatch_hash']}\n")
    return rows


def transparent_series(c: TransparentConfig, out: Path, log=None) -> list[dict]:
    """The study of `c` into out/transparent.csv; none without scenes (a stale file removed)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..errors import UserError
    from ..pipeline.renderer import Renderer
    files = series_files(out, (CSV,), bool(c.scenes) and c.repeat >= 1)
    if files is None:
        return []
    path, = files
    rows: list[dict] = []
    for name in c.scenes:
        scene = study_scene(name, c.lights, c.seed)
        if not scene.transparent_meshes():
            raise UserError(f"transparent study: scene {name} has no transparent surface")
        with Renderer(scene, tuple(c.size), transparent_layers=c.layers) as glass, \
                Renderer(opaque_only(scene), tuple(c.size)) as opaque:
            got = run_scene(glass, opaque, c, log)
        for row in got:
            row.update(scene=name, lights=len(scene.lights))
        rows += got
    write_series(rows, path, COLUMNS, log)
    return rows


class TransparentStudy(FileStudy):
    """out/transparent.csv (the report's transparent section reads it), none of results.csv's rows."""
    name = "transparent"
    files = (CSV,)
    sections = ("transparent",)
    Config = TransparentConfig
    series = staticmethod(transparent_series)


__all__ = ["TransparentConfig", "TransparentStudy", "transparent_series", "run_scene", "serves",
           "opaque_only", "COLUMNS", "CSV", "LOOKED_UP", "REBUILT"]
