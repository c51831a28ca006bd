"""Fog lit from a froxel grid (app/pipeline/fog.py): `DIR/fog.csv` and `DIR/fog_banding.npz`.

On frame 0 of each fog scene, on one froxel grid (`froxels`, its columns and rows at most
the image's), every technique that serves froxels (its declared `froxels`) renders the
frame with its fog, once untimed (compiles; read back: its froxel light sets held to
brute's on the same grid, its pixels to brute's), then `repeat` interleaved rounds of
timing samples, one render of each technique a round.  A row a technique (kind "froxels"):

    source                 where its froxels' candidates come from (FROXEL_SOURCES)
    sets_cpu_ms            the froxel light sets built on the CPU (+ _min / _max)
    fog_cpu_ms             the sets and their upload (+ _min / _max)
    fog_gpu_ms             the fog passes (in-scatter, march, composite; + _min / _max)
    frame_cost_ms          the technique's frame without its fog (CPU stage + timed passes
                           but the G-buffer), for scale
    lights_pf, candidates_pf, unneeded_pf   per froxel on average: the lights it meets, the
                           candidates it was given, those it did not need (the frame's grid)
    froxels_matched, unneeded_pf_matched    the matched grid (a froxel per cell of the
                           technique's own grid) and the not-needed figure there (cell
                           techniques; blank for brute, whose candidates are every light)
    froxel_mismatch        froxels whose count or hash differ from brute's (0)
    mismatch_count / mismatch_hash   pixels that differ from brute's (0)

A technique that refuses a fog scene is a row of kind "refused" with its one-line reason.
The banding case (app.fog_banding.banding, kind "banding", a row a grid): the first
technique that takes the centre-cell lookup, with the lights' radii times `radius_scale`,
lit at 8 samples a froxel, on the study's grid and on the matched grid: the shortcut's
largest error over the brightest pixel and its share of pixels more than 1% off; the
images (exact, shortcut, difference x10, as shown) in fog_banding.npz, "<grid>/<kind>".
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import sys

import numpy as np

from ..results import stats
from . import measure
from .study import FileStudy, series_files, study_scene, write_series

CSV = "fog.csv"                # read by app.report.fog (not imported from there: GL)
BANDING = "fog_banding.npz"    # the banding case's images (app.report.fog)
FROXELS, REFUSED, BANDING_KIND = "froxels", "refused", "banding"
# the CPU steps render_fog adds to a frame's cpu_ms (app/pipeline/fog.py): the sets first
FOG_CPU_STEPS = ("froxels", "froxel_upload")

COLUMNS = ["study", "kind", "scene", "lights", "visible", "width", "height", "frame", "technique",
           "role", "source", "refusal", "froxels", "froxel_count_total", "lights_pf",
           "candidates_pf", "unneeded_pf", "froxels_matched", "unneeded_pf_matched",
           "sets_cpu_ms", "sets_cpu_min_ms", "sets_cpu_max_ms",
           "fog_cpu_ms", "fog_cpu_min_ms", "fog_cpu_max_ms",
           "fog_gpu_ms", "fog_gpu_min_ms", "fog_gpu_max_ms", "fog_passes",
           "frame_cost_ms", "frame_cost_min_ms", "frame_cost_max_ms", "samples",
           "froxel_mismatch", "mismatch_count", "mismatch_hash",
           "grid", "radius_scale", "froxel_samples", "error", "pixels_off"]


@dataclass(frozen=True)
class FogConfig:
    """The study's settings: frame 0 of each of `scenes` (fog scenes; () none) at `lights`
    lights and `size`, on a `froxels` grid (W and H at most the image's), `repeat` timing
    samples a technique; the banding case with the lights' radii times `radius_scale`."""
    scenes: tuple[str, ...]
    lights: int
    size: tuple[int, int]
    froxels: tuple[int, int, int]
    repeat: int
    radius_scale: float = 0.2
    seed: int = 0


def grid_dims(c: FogConfig) -> tuple[int, int, int]:
    """The study's grid, its columns and rows at most the image's pixels."""
    w, h, d = c.froxels
    return min(w, c.size[0]), min(h, c.size[1]), d


def split(meta: dict, fog_passes) -> tuple[dict, dict, float]:
    """(the fog's sample {"cpu_ms": sets and upload, "gpu_ms": its passes}, the frame's
    sample without the fog, the sets' CPU ms) of one render."""
    cpu, gpu = meta["cpu_ms"], meta["gpu_ms"]
    fog = {"cpu_ms": {k: cpu[k] for k in FOG_CPU_STEPS if k in cpu},
           "gpu_ms": {k: gpu[k] for k in fog_passes if k in gpu}}
    frame = {"cpu_ms": {k: v for k, v in cpu.items() if k not in FOG_CPU_STEPS},
             "gpu_ms": {k: v for k, v in gpu.items() if k not in fog_passes}}
    return fog, frame, float(cpu.get(FOG_CPU_STEPS[0], 0.0))


def same_grid(a, b) -> bool:
    return a.dims == b.dims and all(np.array_equal(getattr(a, k), getattr(b, k))
                                    for k in ("xs", "ys", "zs"))


def froxel_mismatch(res, ref) -> int:
    return int(((res.froxel_count != ref.froxel_count) | (res.froxel_hash != ref.froxel_hash)).sum())


def run_scene(renderer, c: FogConfig, log=None) -> list[dict]:
    """The rows of one fog scene's frame 0 (its renderer), banding case aside."""
    from ..pipeline import fog as fogmod
    from ..techniques import REGISTRY, with_role
    log = log or sys.stderr
    fo = fogmod.FogOptions(grid_dims(c))
    renderer.fog_options = fo
    brute = with_role("reference")
    refs = [renderer.render(brute)]                 # brute's frame on the study's grid
    rows, serving = [], []
    for t in REGISTRY.values():
        why = fogmod.refusal(t, t.Options(), fo)
        if why:
            rows.append(dict(kind=REFUSED, technique=t.name, role=t.role, refusal=why))
            continue
        first = renderer.render(t)                  # compiles; read back
        ref = next((r for r in refs if same_grid(r.froxel_grid, first.froxel_grid)), None)
        if ref is None:                             # brute on this technique's own grid
            renderer.fog_options = fogmod.FogOptions(first.froxel_grid)
            refs.append(ref := renderer.render(brute))
            renderer.fog_options = fo
        serving.append((t, first, ref, [], [], []))
    names = [p.name for p in fogmod.passes(refs[0].froxel_grid, renderer.scene.fog, fo,
                                           renderer.size)]
    for _ in range(c.repeat):                       # interleaved rounds
        for t, _, _, fogs, frames, sets in serving:
            f, fr, s = split(renderer.render(t, readback=False).meta, names)
            fogs.append(f)
            frames.append(fr)
            sets.append(s)
    for t, first, ref, fogs, frames, sets in serving:
        st = first.meta["stats"]
        fc, frc = measure.timing_cells(fogs), measure.timing_cells(frames)
        w, h, d = first.froxel_grid.dims
        row = dict(kind=FROXELS, technique=t.name, role=t.role, source=fogmod.source_of(t),
                   froxels=f"{w}x{h}x{d}", froxel_count_total=first.froxel_grid.count,
                   visible=int(st.get("visible_lights", 0)),
                   lights_pf=st["froxel_lights_mean"], candidates_pf=st["froxel_candidates_mean"],
                   unneeded_pf=st["froxel_unneeded_mean"],
                   froxels_matched=st.get("froxels_matched", ""),
                   unneeded_pf_matched=st.get("froxel_unneeded_mean_matched", float("nan")),
                   fog_cpu_ms=fc["cpu_total_ms"], fog_cpu_min_ms=fc["cpu_total_min_ms"],
                   fog_cpu_max_ms=fc["cpu_total_max_ms"], fog_gpu_ms=fc["gpu_lighting_ms"],
                   fog_gpu_min_ms=fc["gpu_lighting_min_ms"], fog_gpu_max_ms=fc["gpu_lighting_max_ms"],
                   fog_passes=fc["gpu_passes"], frame_cost_ms=frc["frame_cost_ms"],
                   frame_cost_min_ms=frc["frame_cost_min_ms"],
                   frame_cost_max_ms=frc["frame_cost_max_ms"], samples=fc["samples"],
                   froxel_mismatch=froxel_mismatch(first, ref))
        row["sets_cpu_ms"], row["sets_cpu_min_ms"], row["sets_cpu_max_ms"] = stats(sets)
        row["mismatch_count"], row["mismatch_hash"] = measure.mismatches(first, ref)
        rows.append(row)
        log.write(f"bench: fog {t.name} ({row['source']}): sets {row['sets_cpu_ms']:.1f} ms CPU, "
                  f"fog passes {row['fog_gpu_ms']:.2f} ms GPU, {row['candidates_pf']:g} candidates "
                  f"a froxel, {row['unneeded_pf']:g} not needed (matched grid "
                  f"{row['unneeded_pf_matched']:g}), froxel mismatches {row['froxel_mismatch']}\n")
    return rows


def banding_technique():
    """The first technique of the registry that takes the centre-cell lookup, or None."""
    from ..pipeline import fog as fogmod
    from ..techniques import REGISTRY
    centre = fogmod.FogOptions(lookup="centre")
    return next((t for t in REGISTRY.values() if fogmod.refusal(t, t.Options(), centre) is None), None)


def banding_rows(scene, c: FogConfig) -> tuple[list[dict], dict[str, np.ndarray]]:
    """The banding case's rows (one a grid) and images ({"<grid>/<kind>": uint8 image})."""
    from ..fog_banding import banding, banding_images
    t = banding_technique()
    if t is None:
        return [], {}
    rows, shown = [], {}
    for grid, r in banding(scene, t, tuple(c.size), grid_dims(c), c.radius_scale).items():
        rows.append(dict(kind=BANDING_KIND, technique=t.name, role=t.role, grid=grid,
                         radius_scale=c.radius_scale, froxel_samples=8, error=r["error"],
                         pixels_off=r["pixels_off"]))
        shown.update({f"{grid}/{k}": v for k, v in banding_images(r).items()})
    return rows, shown


def fog_series(c: FogConfig, out: Path, log=None) -> list[dict]:
    """The study of `c` into out/fog.csv and out/fog_banding.npz; none without scenes (stale
    files removed)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..errors import UserError
    from ..pipeline.renderer import Renderer
    files = series_files(out, (CSV, BANDING), bool(c.scenes) and c.repeat >= 1)
    if files is None:
        return []
    path, npz = files
    rows: list[dict] = []
    images: dict[str, np.ndarray] = {}
    for name in c.scenes:
        scene = study_scene(name, c.lights, c.seed)
        if scene.fog is None:
            raise UserError(f"fog study: scene {name} has no fog")
        with Renderer(scene, tuple(c.size)) as r:
            got = run_scene(r, c, log)
        more, shown = banding_rows(scene, c)
        for k, v in shown.items():
            images[f"{name}/{k}"] = v
        for row in more:
            log.write(f"bench: fog banding {row['technique']} on {row['grid']}: largest error "
                      f"{row['error']:.4g}, {100 * row['pixels_off']:.2f}% of pixels off by more than 1%\n")
        for row in got + more:
            row.update(study="fog", scene=name, lights=len(scene.lights), width=c.size[0],
                       height=c.size[1], frame=0)
        rows += got + more
    np.savez_compressed(npz, **images)
    write_series(rows, path, COLUMNS, log, also=str(npz))
    return rows


class FogStudy(FileStudy):
    """out/fog.csv and out/fog_banding.npz (the report's fog section reads them), none of
    results.csv's rows."""
    name = "fog"
    files = (CSV, BANDING)
    sections = ("fog",)
    Config = FogConfig
    series = staticmethod(fog_series)


__all__ = ["FogConfig", "FogStudy", "fog_series", "run_scene", "banding_rows", "banding_technique",
           "grid_dims", "COLUMNS", "CSV", "BANDING"]
