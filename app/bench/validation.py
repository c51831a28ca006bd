"""The papers' own settings, rendered at their resolution (1920x1080) and modelled only:
what the GPU cost model (app.model) predicts where the papers published a measurement.
The report's validation section sets each beside the published figure (app.report.validation).

    paper_fig7         tree paper figure 7: clustered, tree, hybrid along paper_frames
                       frames spread over the camera path at paper_lights (8k-65k); "CTF-TitanPass" (lights in the level's box) is the lab's
                       arena, "EpicCitadel" (lights on geometry, long views) its city.  The
                       paper chose "a light size distribution which results in low per-pixel
                       overdraw ... only a few light sources affect each pixel" at every
                       count: the builtin scenes keep their radii as the count grows (at 65k
                       the arena has ~40 lights on a pixel), so here the radii shrink by
                       (8192 / n)^(1/3), which keeps each pixel's overdraw at its 8k value
    paper_zbin_table   Drobot's optimization table: the four zbin_variant rows, a 256-light
                       bit array (Zombies opening scene: the lab's hangar, ZBIN_SCENE), on
                       zbin's CPU tiles and (config raster) on raster's rasterized
                       tiles (the slides' own pipeline).  The slides' hangar (tiled vs
                       + z-bin) is read from the same rows: a second render would be the
                       same frame
    paper_cluster_raster  (config raster) Drobot's cluster rasterizer table: raster
                       --cluster 1 at each raster_variant, 256 lights in ZBIN_SCENE, the
                       slides' 60x40x32 grid (CLUSTER_TILE-px clusters: 60 x 34 at 1080p,
                       CLUSTER_SLICES slices)
    paper_cluster_tile (config raster) the same, atomic, at each of CLUSTER_TILES px
                       (the table's row at CLUSTER_TILE): what the clusters' size wastes
    paper_fptl         Mikkelsen's interior at 1080p: fine-pruned vs coarse lists (the lab's
                       corridor, 1,024 lights: the chapter's 10-bit index limit)
    paper_fptl_visible the same at the chapter's own scene size, "no more than 40-120 lights
                       inside the camera frustum": the corridor's lights up to its 40th, 80th
                       and 120th visible one (FPTL_VISIBLE)
    paper_scenes       every builtin scene at 4,096 lights: the modelled ranking per GPU

Each configuration is rendered once on llvmpipe with its shading passes' CELLS_ONLY switch:
the G-buffer, the CPU stage and the culling passes run, and the shading pass records each
pixel's cell without running its light loops (at 1080p they would cost llvmpipe seconds a
frame and say nothing the path study does not).  The wave replay, over every
`paper_sample`-th 8x8 group (figure 7's: `paper_path_sample`-th) and scaled, stands for
the shading loops; the row's per-pixel figures are the replay's (tests/app/model: they
equal the shaders' counters).  No timing samples, no exactness columns: the same techniques are checked at the path resolution.
The floor (perfect) is left out of paper_scenes: its untimed set-up tests every light at
every pixel, minutes a 1080p frame on llvmpipe.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..results import PAPER_PREFIX
from ..techniques import REGISTRY
from .plan import Job
from .study import Shared, Study

FIG7_SCENES = ("arena", "city")
FIG7_TECHNIQUES = ("clustered", "tree", "hybrid")
ZBIN_LIGHTS = 256                 # the slides' 256-bit array
# the optimization table's scene: the slides' pass is mostly lighting (5.7 ms on a PS4); the
# lab's interior of large overlapping lights loads lighting like that (arena's 256 lights
# light 0.2 a pixel: a pass at the bandwidth floor, where no variant can show)
ZBIN_SCENE = "hangar"
FPTL_LIGHTS = 1024                # the chapter's 10-bit indices
FPTL_VISIBLE = (40, 80, 120)      # the chapter's "40-120 lights inside the camera frustum"
CLUSTER_TILE = 32                 # the slides' 60 columns at 1920 px (their 40 rows: 27 px)
CLUSTER_SLICES = 32
CLUSTER_TILES = (8, 16, 32, 64)   # the cluster_tile sweep: is the clusters' waste their size?


FIG7_BASE = 8192                  # figure 7's radii: the overdraw of this count at every count


@dataclass(frozen=True)
class PaperJob:
    job: Job
    frames: int                   # the camera path's frames for job.frame
    radius_scale: float = 1.0     # the scene's light radii times this
    visible: int = 0              # the scene's lights up to its visible-th visible one (0: all)
    sample: int = 0               # the shading replay's sample (0: the config's sample)


def scaled_lights(lights, scale: float):
    """The lights with every size (radius, capsule length, box extent) times `scale`."""
    if scale == 1.0:
        return lights
    out = lights.copy()
    out["radius"] *= scale
    out["length"] *= scale
    out["extent"] *= scale
    return out


def visible_prefix(lights, frame_input, k: int):
    """The scene's lights up to and including its k-th visible one (in scene order) in the
    frame of `frame_input`: exactly k visible lights (all of them where fewer are)."""
    from cpu_prep.lights import cull
    keyed, _ = cull(lights, frame_input.camera, frame_input.arena)
    ids = np.sort(keyed & np.uint64(0xFFFFFFFF)).astype(np.int64)
    return lights if len(ids) <= k else lights[:int(ids[k - 1]) + 1]


def job_lights(pj: PaperJob, lights, frame_input):
    """The lights a paper job renders: the scene's at its frame, sized and cut as it says."""
    lights = scaled_lights(lights, pj.radius_scale)
    return visible_prefix(lights, frame_input(lights), pj.visible) if pj.visible else lights


@dataclass(frozen=True)
class PapersConfig:
    """The papers' settings, modelled only, at `size` (None: none); the scenes study runs in
    the rendered scenes at the option studies' count (shared)."""
    shared: Shared
    size: tuple[int, int] | None = (1920, 1080)
    lights: tuple[int, ...] = (8192, 16384, 32768, 65536)
    frames: int = 16              # camera-path frames of figure 7, spread over each path
    sample: int = 8               # the shading replay over every k-th 8x8 group (scaled)
    path_sample: int = 0          # ... figure 7's rows (0: sample)
    raster: bool = True           # raster's rows of Drobot's tables (zbin table, cluster table)
    replay_segments: int = 0      # the replay's limit on a program's segments (0: none; as
                                  # app.bench.rendered's: predict.frame_figures)


def paper_jobs(c: PapersConfig) -> list[PaperJob]:
    """The papers' configurations (none when the config has no size)."""
    if not c.size:
        return []
    out = []

    def add(study, scene, lights, frame, name, frames=1, scale=1.0, visible=0, sample=0, **opts):
        t = REGISTRY[name]
        out.append(PaperJob(Job(PAPER_PREFIX + study, scene, lights, frame, name,
                                t.Options().with_(**opts)), frames, scale, visible, sample))

    for scene in FIG7_SCENES:
        for n in c.lights:
            for f in range(c.frames):
                for name in FIG7_TECHNIQUES:
                    add("fig7", scene, n, f, name, c.frames, (FIG7_BASE / n) ** (1 / 3),
                        sample=c.path_sample)
    for name in ("zbin", "raster") if c.raster else ("zbin",):
        for v in range(4):
            add("zbin_table", ZBIN_SCENE, ZBIN_LIGHTS, 0, name, zbin_variant=v)
    for v in range(4 if c.raster else 0):
        add("cluster_raster", ZBIN_SCENE, ZBIN_LIGHTS, 0, "raster", raster_variant=v, cluster=1,
            cluster_tile=CLUSTER_TILE, cluster_slices=CLUSTER_SLICES)
    for tile in CLUSTER_TILES if c.raster else ():
        if tile != CLUSTER_TILE:                   # that one is the cluster table's first row
            add("cluster_tile", ZBIN_SCENE, ZBIN_LIGHTS, 0, "raster", cluster=1,
                cluster_tile=tile, cluster_slices=CLUSTER_SLICES)
    for v in (0, 1):
        add("fptl", "corridor", FPTL_LIGHTS, 0, "fptl", fptl_variant=v)
    for k in FPTL_VISIBLE:
        for v in (0, 1):
            add("fptl_visible", "corridor", FPTL_LIGHTS, 0, "fptl", visible=k, fptl_variant=v)
    for scene in c.shared.scenes:
        for name, t in REGISTRY.items():
            if t.role != "floor":
                add("scenes", scene, c.shared.study_lights, 0, name)
    return out


class PapersStudy(Study):
    """The papers' configurations at the papers' resolution (paper_jobs), modelled only: one
    read-back render each, its wave figures and modelled GPU ms, no timing samples.  Rows of
    results.csv (studies "paper_*"; the report's validation and model sections)."""
    name = "papers"
    sections = ("validation", "model")
    Config = PapersConfig

    def run(self, out, sweep) -> list[dict]:
        from ..model import predict
        from ..pipeline.renderer import Renderer
        from . import measure
        c = self.config
        jobs = paper_jobs(c)
        rows = []
        renderer, current = None, None
        try:
            for i, pj in enumerate(jobs, 1):
                job = pj.job
                if job.scene != current:
                    if renderer is not None:
                        renderer.release()
                    renderer = Renderer(sweep.scene(job.scene, job.lights), c.size)
                    current = job.scene
                renderer.scene = sweep.scene(job.scene, job.lights)
                w, h = c.size
                sweep.progress(i, len(jobs), f"{job.describe()} at {w}x{h} (modelled)")
                tech = REGISTRY[job.technique]
                lights = job_lights(pj, sweep.lights_for(job), lambda L: renderer.frame_input(
                    job.frame, pj.frames, lights=L))
                res = renderer.render(tech, job.frame, job.opts, frames=pj.frames, lights=lights,
                                      defines={"CELLS_ONLY": 1})
                figures, implied = predict.modelled_frame(renderer, tech, res, job.opts,
                                                          sample=pj.sample or c.sample,
                                                          segments=c.replay_segments)
                r = {"study": job.study, "scene": job.scene, "lights": len(lights),
                     "visible": int(res.meta["stats"].get("visible_lights", 0)), "width": w,
                     "height": h, "frame": job.frame, "frames": pj.frames,
                     "technique": tech.name, "role": tech.role, "cutoff": 0}
                r.update(measure.option_cells(job.opts))
                r.update(measure.figure_cells(res))
                r.update(implied)                  # the shading loops did not run on llvmpipe
                r.update(measure.model_cells(figures))
                r["cpu_total_ms"] = float(sum(res.meta["cpu_ms"].values()))
                r.update(measure.model_frame_cells(r))
                rows.append(r)
        finally:
            if renderer is not None:
                renderer.release()
        return rows
