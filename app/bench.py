"""Benchmark: what each culling technique costs and what it gains (DESIGN "Measuring").

    python -m app.bench cpu --scene S --technique T [--lights N] [--size WxH] [--tile 48]
                            [--slices 16] [--repeat R] [--threads 1] [--json]
        The CPU stage alone (no GL context at all): technique.build R times after a warm-up
        (numba JIT), median/min/max ms of each stage (cull, sort, bin, build, pack) and total.

    python -m app.bench [--quick|--full] --out DIR [--size WxH] [--scenes a,b] [--lights 1024,4096]
                        [--frames K] [--repeat R] [--threads 1]
        The sweep: scenes x every technique of the registry (+ the perfect culler) x light
        counts x camera-path frames, plus option studies (tile size, hybrid radius scale,
        duplicated vs indexed lists, the light cutoff) and a CPU-only light-count series.
        Writes DIR/results.csv (one row per measured frame and configuration), DIR/maps.npz
        (per-block maps for the figures) and DIR/report.md with its PNG plots (app.report).

Studies (column `study` of results.csv):
    path      every technique + perfect, every scene, light count and path frame (figure 7)
    tile      tile size 16..64 for every technique whose build depends on it (figure 6)
    radius    Options.radius_scale for every technique whose build depends on it
    layout    Options.duplicated False/True for every technique whose build depends on it
    cutoff    the threshold that sets each light's radius (see cutoff_lights) against an
              unbounded reference (every light, no window), every technique + perfect
    cpu       technique.build only, at the CPU preset's resolution and light counts (figure 4)
    cpu_tile  technique.build only at the CPU resolution, tile sizes of the tile study (figure 6)
Which techniques a study covers is found by building with each option value and comparing
the outputs, never by name, so a technique added to REGISTRY appears with no change here.

CPU threads: the CPU stage runs on `--threads` numba threads, 1 by default as in the tree
paper's figure 4 ("single threaded").  On small VMs numba's parallel regions can cost more than
the work (a thread wake-up waits for the scheduler tick), so compare thread counts with care.

Timing: every configuration is rendered once with read-back (counters, image) and then
repeated; the first render of a program in the process is a discarded warm-up (shader and
numba compilation).  A configuration whose loop evaluates more than `heavy_eval_pp` lights a
pixel (brute) is repeated `heavy_repeat` times only.  The sample counts depend only on the
command, so the same command gives the same table apart from the timing columns.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
import csv
import hashlib
import json
import math
import os
from pathlib import Path
import platform
import sys
import time

import numpy as np

from . import cli
from .errors import UserError
from cpu_prep.arena import Arena
from .techniques import REGISTRY, FrameInput, Options, get

REFERENCE = "brute"            # the exactness reference of the dump contract
PERFECT = "perfect"            # app.perfect, the shading floor
CPU_STAGES = ("cull", "sort", "bin", "build", "pack")
UPLOAD = "upload"
# The tree paper's CPU step shares (4.1, tree creation on an i7-4790K); pack is not named there.
PAPER_SHARES = {"bin": 50.0, "build": 25.0, "sort": 12.0, "upload": 7.0, "cull": 3.0}


# ---------------------------------------------------------------------------- presets

@dataclass(frozen=True)
class Preset:
    name: str
    size: tuple[int, int]
    scenes: tuple[str, ...]
    lights: tuple[int, ...]
    frames: int                   # frames sampled evenly along the camera-path loop
    repeat: int
    heavy_repeat: int             # repeats of a configuration evaluating > heavy_eval_pp lights/px
    heavy_eval_pp: float
    tiles: tuple[int, ...]        # tile-size study (tree paper figure 6)
    radius_scales: tuple[float, ...]
    cutoffs: tuple[int, ...]      # light cutoff t = 1 / value, relative to the brightest light
    cutoff_scenes: tuple[str, ...]
    cutoff_lights: int
    study_scene: str              # scene, light count (frame 0) of the tile/radius/layout studies
    study_lights: int
    heat_scene: str               # the frame of the heat maps and classification (figures 1, 3)
    cpu_scene: str
    cpu_size: tuple[int, int]     # the CPU series runs at the paper's resolution even in --quick
    cpu_lights: tuple[int, ...]
    cpu_repeat: int
    seed: int = 0
    cpu_threads: int = 1          # numba threads of the CPU stage (0: numba's default)
    tile: int = 48                # paper defaults for every other study
    slices: int = 16


QUICK = Preset(
    name="quick", size=(320, 180), scenes=("arena", "city", "hangar", "gallery"),
    lights=(1024, 4096), frames=8, repeat=3, heavy_repeat=1, heavy_eval_pp=256.0,
    tiles=(16, 32, 48, 64), radius_scales=(0.5, 1.0, 2.0, 4.0),
    cutoffs=(256, 1024, 4096, 16384, 65536), cutoff_scenes=("arena", "city"), cutoff_lights=2048, study_scene="arena", study_lights=4096,
    heat_scene="city", cpu_scene="arena", cpu_size=(1920, 1080),
    cpu_lights=(1024, 4096, 16384, 65536), cpu_repeat=5)

FULL = Preset(
    name="full", size=(1920, 1080), scenes=("arena", "city", "hangar", "gallery"),
    lights=(8192, 16384, 32768, 65536), frames=64, repeat=5, heavy_repeat=2,
    heavy_eval_pp=4096.0, tiles=(16, 32, 48, 64), radius_scales=(0.25, 0.5, 1.0, 2.0, 4.0),
    cutoffs=(256, 1024, 4096, 16384, 65536), cutoff_scenes=("arena", "city"),
    cutoff_lights=16384, study_scene="arena", study_lights=32768, heat_scene="city",
    cpu_scene="arena", cpu_size=(1920, 1080),
    cpu_lights=(1024, 2048, 4096, 8192, 16384, 32768, 65536), cpu_repeat=9)

PRESETS = {"quick": QUICK, "full": FULL}


# ---------------------------------------------------------------------------- cutoff rule

def light_intensity(lights: np.ndarray) -> np.ndarray:
    """Peak radiance scale of each light: intensity x brightest colour channel."""
    return lights["intensity"].astype(np.float64) * lights["color"].astype(np.float64).max(1)


def cutoff_lights(lights: np.ndarray, cutoff: float, i_ref: float | None = None) -> np.ndarray:
    """The lights with each radius set where the unbounded falloff drops to `cutoff` of the
    reference intensity:

        I_i / (d^2 + 1) = t * I_ref   ->   radius_i = sqrt(I_i / (t * I_ref) - 1)

    I_ref is the brightest light of the scene (so t = 1/256 drops what stays below one 8-bit
    step of the brightest light's peak).  The radius grows as sqrt(I_i): the builtin scenes
    draw I_i ~ r_i^2, so the scene's many-small-few-large radius law is kept, scaled by
    sqrt(1/t).  A light never brighter than t * I_ref (I_i <= t * I_ref) affects nothing and
    is dropped."""
    inten = light_intensity(lights)
    i_ref = float(inten.max()) if i_ref is None and len(lights) else float(i_ref or 1.0)
    q = inten / (cutoff * i_ref) - 1.0
    keep = q > 1e-6
    out = lights[keep].copy()
    out["radius"] = np.sqrt(q[keep]).astype(np.float32)
    return out


def unbounded_lights(lights: np.ndarray, scene) -> np.ndarray:
    """The reference's lights: a radius past every point of the scene, so that the frustum
    cull keeps all of them (UNBOUNDED_FALLOFF ignores the radius when shading)."""
    lo, hi = scene.bounds()
    far = max(float(np.linalg.norm(hi - lo)), scene.camera.far)
    out = lights.copy()
    out["radius"] = np.float32(4.0 * far + 1.0)
    return out


# ---------------------------------------------------------------------------- CPU stage

def cpu_stage_samples(technique, scene, size, opts: Options, repeat: int, frame: int = 0,
                      frames: int = 64, lights=None, upload=None, warmup: int = 1) -> dict:
    """technique.build `repeat` times (after `warmup` unrecorded builds) on the scene's camera
    at `frame`: per-stage lists of ms (every stage of CPU_STAGES, 0 where a technique has
    none), 'total', and the visible light count.  `upload(build) -> ms` adds an upload stage."""
    from cpu_prep.camera import frame_camera
    w, h = size
    cam = frame_camera(scene.camera_at(frame, frames), w, h)
    lights = scene.lights if lights is None else lights
    # one arena across the repeats: the frame-to-frame reuse an engine (and the Renderer) has
    fi = FrameInput(lights, cam, scene.max_depth or cam.far, Arena())
    for _ in range(warmup):
        technique.build(fi, opts)
    stages = list(CPU_STAGES) + ([UPLOAD] if upload else [])
    out = {k: [] for k in stages + ["total"]}
    visible = 0
    for _ in range(repeat):
        b = technique.build(fi, opts)
        ms = dict(b.times.ms)
        if upload:
            ms[UPLOAD] = upload(b)
        for k in stages:
            out[k].append(float(ms.get(k, 0.0)))
        out["total"].append(float(sum(ms.values())))
        visible = int(b.stats.get("visible_lights", 0))
    out["visible"] = visible
    return out


def set_cpu_threads(n: int) -> int:
    """Run the CPU stage's numba kernels on n threads (0: leave numba's default); returns
    the count in use."""
    import numba
    if n > 0:
        numba.set_num_threads(min(int(n), numba.config.NUMBA_NUM_THREADS))
    return int(numba.get_num_threads())


def _stats(values) -> tuple[float, float, float]:
    a = np.asarray(values, np.float64)
    return (float(np.median(a)), float(a.min()), float(a.max())) if len(a) else (math.nan,) * 3


def cpu_main(argv) -> None:
    p = cli.Parser(prog="python -m app.bench cpu",
                   description="CPU stage of one technique, no GL context")
    cli.add_scene_args(p)
    p.add_argument("--technique", default="hybrid", help="technique id")
    p.add_argument("--frame", type=int, default=0, help="camera path frame (of --frames)")
    p.add_argument("--frames", type=int, default=64, help="length of the camera path loop")
    p.add_argument("--repeat", type=int, default=9, help="measured builds (after one warm-up)")
    p.add_argument("--threads", type=int, default=1,
                   help="numba threads of the CPU stage (default 1, as the paper; 0: all)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    cli.add_option_args(p)
    args = p.parse_args(argv)
    if args.repeat < 1 or args.frames < 1 or args.frame < 0 or args.threads < 0:
        raise UserError("--repeat and --frames must be >= 1, --frame and --threads >= 0")
    threads = set_cpu_threads(args.threads)
    technique = get(args.technique)
    opts = cli.options_from(args)
    scene = cli.load_scene_args(args)
    size = tuple(args.size or scene.resolution)
    s = cpu_stage_samples(technique, scene, size, opts, args.repeat, args.frame, args.frames)
    keys = list(CPU_STAGES) + ["total"]
    st = {k: _stats(s[k]) for k in keys}
    out = {
        "technique": technique.name, "scene": args.scene, "size": list(size),
        "lights": int(len(scene.lights)), "visible": s["visible"], "repeat": args.repeat,
        "threads": threads,
        "options": opts.as_dict(),
        "median_ms": {k: round(st[k][0], 4) for k in keys},
        "min_ms": {k: round(st[k][1], 4) for k in keys},
        "max_ms": {k: round(st[k][2], 4) for k in keys},
    }
    if args.json:
        print(json.dumps(out))
        return
    print(f"{technique.name} on {args.scene} at {size[0]}x{size[1]}: {out['lights']} lights, "
          f"{out['visible']} visible, {args.repeat} builds after a warm-up, {threads} thread(s)")
    print(f"{'stage':8} {'median ms':>10} {'min ms':>10} {'max ms':>10} {'share':>7}")
    tot = st["total"][0] or 1.0
    for k in keys:
        share = "" if k == "total" else f"{100 * st[k][0] / tot:6.1f}%"
        print(f"{k:8} {st[k][0]:10.3f} {st[k][1]:10.3f} {st[k][2]:10.3f} {share:>7}")


# ---------------------------------------------------------------------------- the sweep

COLUMNS = [
    "study", "scene", "lights", "visible", "width", "height", "frame", "frames", "technique",
    "tile", "slices", "radius_scale", "duplicated", "cutoff", "samples",
    *[f"cpu_{k}_ms" for k in CPU_STAGES], "cpu_upload_ms", "cpu_total_ms", "cpu_total_min_ms",
    "cpu_total_max_ms",
    "gpu_gbuffer_ms", "gpu_gbuffer_min_ms", "gpu_gbuffer_max_ms",
    "gpu_cull_ms", "gpu_cull_min_ms", "gpu_cull_max_ms",
    "gpu_shade_ms", "gpu_shade_min_ms", "gpu_shade_max_ms", "gpu_passes",
    "frame_cost_ms", "evaluated_pp", "exact_pp", "waste", "nodes_pp", "wave_iters",
    "bytes_lights", "bytes_culling", "error_ref", "image_error", "radiance_ratio", "mismatch_count",
    "mismatch_hash", "floor_position_pct",
]
TIMING_COLUMNS = {c for c in COLUMNS if c.endswith("_ms")} | {"gpu_passes", "floor_position_pct"}


@dataclass(frozen=True)
class Job:
    study: str
    scene: str
    lights: int
    frame: int
    technique: str                # a REGISTRY id, or PERFECT
    opts: Options
    cutoff: int = 0               # 0: the scene's own radii; -1: unbounded reference

    def describe(self) -> str:
        extra = {"tile": f"tile {self.opts.tile}", "radius": f"radius_scale {self.opts.radius_scale}",
                 "layout": "duplicated" if self.opts.duplicated else "indexed",
                 "cutoff": ("unbounded" if self.cutoff < 0 else f"t=1/{self.cutoff}")}.get(self.study, "")
        return f"{self.study} {self.scene} {self.lights} lights f{self.frame} {self.technique} {extra}".strip()


def _signature(b) -> tuple:
    bufs = tuple(sorted((k, a.nbytes, hashlib.sha1(np.ascontiguousarray(a).tobytes()).hexdigest())
                        for k, a in b.buffers.items()))
    return bufs, repr(sorted(b.uniforms.items())), repr(sorted(b.defines.items()))


def depends_on(technique, fi: FrameInput, base: Options, field: str, values) -> bool:
    """Whether the technique's build changes with Options.<field> over `values`."""
    sigs = {_signature(technique.build(fi, replace(base, **{field: v}))) for v in values}
    return len(sigs) > 1


class Sweep:
    def __init__(self, preset: Preset, out: Path, command: str, log=sys.stderr):
        self.p = preset
        self.out = out
        self.command = command
        self.log = log
        self.rows: list[dict] = []
        self.maps: dict[str, np.ndarray] = {}
        self.warm: set = set()
        self.refs: dict = {}          # (scene, lights, frame, cutoff) -> brute's FrameResult
        self.light_sets: dict = {}    # (scene, lights, cutoff) -> light array
        self.scenes: dict = {}
        self.t0 = time.perf_counter()
        self.base = Options(tile=preset.tile, slices=preset.slices)

    # ---- scenes and lights ----------------------------------------------------------------

    def scene(self, name: str, lights: int):
        from scenes import BUILTIN_SCENES, load_scene
        key = (name, lights)
        if key not in self.scenes:
            n = lights if name in BUILTIN_SCENES else None
            self.scenes[key] = load_scene(name, lights=n, seed=self.p.seed)
        return self.scenes[key]

    def light_counts(self, name: str, counts) -> tuple[int, ...]:
        from scenes import BUILTIN_SCENES
        if name in BUILTIN_SCENES:
            return tuple(counts)
        return (len(self.scene(name, 0).lights),)   # a scene file: its own lights

    def lights_for(self, job: Job):
        sc = self.scene(job.scene, job.lights)
        if job.cutoff == 0:
            return sc.lights
        key = (job.scene, job.lights, job.cutoff)
        if key not in self.light_sets:
            self.light_sets[key] = (unbounded_lights(sc.lights, sc) if job.cutoff < 0
                                    else cutoff_lights(sc.lights, 1.0 / job.cutoff))
        return self.light_sets[key]

    # ---- planning --------------------------------------------------------------------------

    def plan(self) -> list[Job]:
        from cpu_prep.camera import frame_camera
        p, jobs = self.p, []
        # the reference first in every group: the others' exactness and error need it
        names = [REFERENCE] + [t for t in REGISTRY if t != REFERENCE] + [PERFECT]
        study_techs = self.study_techs = {}
        sc = self.scene(p.study_scene, self.light_counts(p.study_scene, (p.study_lights,))[0])
        cam = frame_camera(sc.camera_at(0, p.frames), *p.size)
        fi = FrameInput(sc.lights, cam, sc.max_depth or cam.far)
        for study, field, values in (("tile", "tile", p.tiles), ("radius", "radius_scale", p.radius_scales),
                                     ("layout", "duplicated", (False, True))):
            study_techs[study] = [t for t, tech in REGISTRY.items()
                                  if depends_on(tech, fi, self.base, field, values)]
            self.log.write(f"bench: {study} study ({field}): {', '.join(study_techs[study]) or 'none'}\n")
        for scene in p.scenes:
            for n in self.light_counts(scene, p.lights):
                for f in range(p.frames):
                    jobs += [Job("path", scene, n, f, t, self.base) for t in names]
            if scene == p.study_scene:
                n = self.light_counts(scene, (p.study_lights,))[0]
                for study, field, values in (("tile", "tile", p.tiles),
                                             ("radius", "radius_scale", p.radius_scales),
                                             ("layout", "duplicated", (False, True))):
                    for v in values:
                        opts = replace(self.base, **{field: v})
                        jobs += [Job(study, scene, n, 0, t, opts) for t in study_techs[study]]
            if scene in p.cutoff_scenes:
                n = self.light_counts(scene, (p.cutoff_lights,))[0]
                jobs.append(Job("cutoff", scene, n, 0, REFERENCE, self.base, cutoff=-1))
                for c in p.cutoffs:
                    jobs += [Job("cutoff", scene, n, 0, t, self.base, cutoff=c) for t in names]
        return jobs

    # ---- measuring -------------------------------------------------------------------------

    def progress(self, i: int, total: int, what: str) -> None:
        self.log.write(f"[{i}/{total} {time.perf_counter() - self.t0:6.1f}s] {what}\n")
        self.log.flush()

    def render(self, renderer, perfect, job: Job, readback: bool):
        lights = self.lights_for(job)
        defines = {"UNBOUNDED_FALLOFF": 1} if job.cutoff < 0 else None
        if job.technique == PERFECT:
            return perfect.render(job.frame, job.opts, self.p.frames, lights=lights,
                                  readback=readback, extra_defines=defines)
        return renderer.render(REGISTRY[job.technique], job.frame, job.opts, frames=self.p.frames,
                               lights=lights, readback=readback, extra_defines=defines)

    def reference(self, renderer, job: Job):
        """brute's frame for the job's scene, lights, frame and cutoff (rendered if missing)."""
        cut = -1 if job.study == "cutoff" and job.cutoff < 0 else job.cutoff
        key = (job.scene, job.lights, job.frame, cut)
        if key not in self.refs:
            ref_job = replace(job, technique=REFERENCE, cutoff=cut)
            self.refs[key] = self.render(renderer, None, ref_job, True)
        return self.refs[key]

    def measure(self, renderer, perfect, job: Job):
        """(row, read-back result) of one configuration."""
        res = self.render(renderer, perfect, job, True)
        types = tuple(np.unique(self.lights_for(job)["type"]).tolist())   # shader features
        key = (id(renderer), job.technique, tuple(job.opts.as_dict().items()), job.cutoff < 0, types)
        samples = [res.meta] if key in self.warm else []
        self.warm.add(key)
        mask = res.depth > 0
        ev = float(res.evaluated[mask].mean()) if mask.any() else 0.0
        reps = self.p.heavy_repeat if ev > self.p.heavy_eval_pp else self.p.repeat
        while len(samples) < reps:
            self.render(renderer, perfect, job, False)
            samples.append(renderer.last_meta)
        if job.technique == REFERENCE and job.cutoff >= 0:
            self.refs[(job.scene, job.lights, job.frame, job.cutoff)] = res
        if job.cutoff < 0:
            self.refs[(job.scene, job.lights, job.frame, -1)] = res
        return self.row(job, res, samples, renderer), res

    def row(self, job: Job, res, samples, renderer) -> dict:
        w, h = renderer.size
        o = job.opts
        r = {"study": job.study, "scene": job.scene, "lights": job.lights,
             "visible": int(res.meta["stats"].get("visible_lights", 0)), "width": w, "height": h,
             "frame": job.frame, "frames": self.p.frames, "technique": job.technique,
             "tile": o.tile, "slices": o.slices, "radius_scale": o.radius_scale,
             "duplicated": int(o.duplicated), "cutoff": job.cutoff, "samples": len(samples)}
        cpu = {k: [float(m["cpu_ms"].get(k, 0.0)) for m in samples] for k in CPU_STAGES + (UPLOAD,)}
        for k, v in cpu.items():
            r[f"cpu_{k}_ms"] = _stats(v)[0]
        tot = _stats([sum(m["cpu_ms"].values()) for m in samples])
        r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = tot
        passes = sorted({k for m in samples for k in m["gpu_ms"]})
        per = {k: _stats([m["gpu_ms"].get(k, 0.0) for m in samples]) for k in passes}
        cull = _stats([sum(v for k, v in m["gpu_ms"].items() if k not in ("gbuffer", "shade"))
                       for m in samples])
        for name, st in (("gbuffer", per.get("gbuffer", (0.0,) * 3)), ("cull", cull),
                         ("shade", per.get("shade", (0.0,) * 3))):
            r[f"gpu_{name}_ms"], r[f"gpu_{name}_min_ms"], r[f"gpu_{name}_max_ms"] = st
        r["gpu_passes"] = ";".join(f"{k}={v[0]:.3f}/{v[1]:.3f}/{v[2]:.3f}" for k, v in per.items())
        if job.technique == PERFECT:    # the floor: shared CPU steps + shading; lists untimed
            r["frame_cost_ms"] = r["cpu_total_ms"] + r["gpu_shade_ms"]
        else:
            r["frame_cost_ms"] = r["cpu_total_ms"] + r["gpu_cull_ms"] + r["gpu_shade_ms"]
        mask = res.depth > 0
        ev = res.evaluated[mask].astype(np.float64)
        ex = res.contrib_count[mask].astype(np.float64)
        r["evaluated_pp"] = float(ev.mean()) if mask.any() else 0.0
        r["exact_pp"] = float(ex.mean()) if mask.any() else 0.0
        r["waste"] = float(ev.sum() / ex.sum()) if ex.sum() > 0 else math.nan
        r["nodes_pp"] = float(res.nodes[mask].mean()) if mask.any() else 0.0
        r["wave_iters"] = float(res.wave[..., 0].mean())
        nbytes = res.meta["bytes"]
        r["bytes_lights"] = int(nbytes.get("lights", 0))
        r["bytes_culling"] = int(sum(v for k, v in nbytes.items() if k != "lights"))
        if job.study == "cutoff":
            ref_err = self.reference(renderer, replace(job, cutoff=-1))
            r["error_ref"] = "unbounded"
        else:
            ref_err = self.reference(renderer, job)
            r["error_ref"] = REFERENCE
        r["image_error"] = image_error(res, ref_err)
        r["radiance_ratio"] = radiance_ratio(res, ref_err)
        if job.study == "cutoff" and job.cutoff < 0:
            r["mismatch_count"] = r["mismatch_hash"] = 0
        else:
            ref = self.reference(renderer, job)
            r["mismatch_count"] = int((res.contrib_count != ref.contrib_count).sum())
            r["mismatch_hash"] = int((res.contrib_hash != ref.contrib_hash).sum())
        r["floor_position_pct"] = math.nan
        return r

    def keep_maps(self, job: Job, res) -> None:
        """Block maps of the heat-map frame (figures 1 and 3)."""
        from .images import block_mean
        p = self.p
        if not (job.study == "path" and job.scene == p.heat_scene and job.frame == 0
                and job.lights == max(self.light_counts(job.scene, p.lights))):
            return
        block = 8 if res.evaluated.shape[1] < 960 else 16
        self.maps["block"] = np.array(block)
        self.maps[f"evaluated/{job.technique}"] = block_mean(res.evaluated.astype(np.float64), block)
        self.maps[f"cases/{job.technique}"] = (res.wave[..., 1] & 3).astype(np.uint8)
        if job.technique == REFERENCE:
            self.maps["exact"] = block_mean(res.contrib_count.astype(np.float64), block)

    def run(self) -> list[dict]:
        from .renderer import Renderer
        from .perfect import PerfectCuller
        jobs = self.plan()
        total = len(jobs)
        self.log.write(f"bench: {self.p.name} preset, {total} configurations + CPU series\n")
        renderer = perfect = None
        current = None
        for i, job in enumerate(jobs, 1):
            if job.scene != current:
                if renderer is not None:
                    perfect.release()
                    renderer.release()
                self.refs.clear()
                self.light_sets.clear()
                sc = self.scene(job.scene, job.lights)
                renderer = Renderer(sc, self.p.size)
                perfect = PerfectCuller(renderer)
                current = job.scene
            renderer.scene = self.scene(job.scene, job.lights)   # same geometry, these lights
            self.progress(i, total, job.describe())
            row, res = self.measure(renderer, perfect, job)
            self.rows.append(row)
            self.keep_maps(job, res)
            del res
            self._forget(job)
        if renderer is not None:
            perfect.release()
            renderer.release()
        fill_floor_positions(self.rows)
        self.cpu_series()
        return self.rows

    def _forget(self, job: Job) -> None:
        """Drop references no later job needs (full-resolution frames are ~50 MB each)."""
        p = self.p
        study_n = self.light_counts(p.study_scene, (p.study_lights,))[0]
        for key in list(self.refs):
            scene, n, frame, cut = key
            keep = (scene == job.scene and n == job.lights and frame == job.frame) or \
                   (scene == p.study_scene and frame == 0 and cut == 0 and n == study_n)
            if not keep:
                del self.refs[key]

    def cpu_series(self) -> None:
        """Figure 4: technique.build alone at cpu_size over cpu_lights; upload timed into GL
        buffers of the process's context, as the renderer does."""
        from . import gl
        p = self.p
        ctx = gl.context()
        scratch: dict[str, object] = {}

        def upload(b) -> float:
            t0 = time.perf_counter()
            for k, a in b.buffers.items():
                buf = scratch.get(k)
                if buf is None or buf.size < a.nbytes:
                    if buf is not None:
                        buf.release()
                    buf = scratch[k] = ctx.buffer(reserve=max(a.nbytes, 16))
                if a.nbytes:
                    buf.write(np.ascontiguousarray(a).tobytes())
            ctx.finish()
            return (time.perf_counter() - t0) * 1e3

        counts = self.light_counts(p.cpu_scene, p.cpu_lights)
        n_tile = self.light_counts(p.study_scene, (p.study_lights,))[0]
        series = [("cpu", p.cpu_scene, n, name, self.base) for n in counts for name in REGISTRY]
        series += [("cpu_tile", p.study_scene, n_tile, name, replace(self.base, tile=t))
                   for t in p.tiles for name in getattr(self, "study_techs", {}).get("tile", ())]
        for i, (study, scene, n, name, opts) in enumerate(series, 1):
            sc = self.scene(scene, n)
            self.progress(i, len(series), f"{study} {scene} {n} lights {name} tile {opts.tile} "
                                          f"at {p.cpu_size[0]}x{p.cpu_size[1]}")
            s = cpu_stage_samples(REGISTRY[name], sc, p.cpu_size, opts, p.cpu_repeat, 0, p.frames,
                                  upload=upload)
            r = {c: "" for c in COLUMNS}
            r.update(study=study, scene=scene, lights=n, visible=s["visible"],
                     width=p.cpu_size[0], height=p.cpu_size[1], frame=0, frames=p.frames,
                     technique=name, tile=opts.tile, slices=opts.slices,
                     radius_scale=opts.radius_scale, duplicated=0, cutoff=0,
                     samples=p.cpu_repeat)
            for k in CPU_STAGES + (UPLOAD,):
                r[f"cpu_{k}_ms"] = _stats(s[k])[0]
            r["cpu_total_ms"], r["cpu_total_min_ms"], r["cpu_total_max_ms"] = _stats(s["total"])
            self.rows.append(r)
        for b in scratch.values():
            b.release()


def image_error(res, ref) -> float:
    """RMSE of linear radiance over geometry pixels, relative to the reference's mean."""
    mask = ref.depth > 0
    if not mask.any():
        return 0.0
    a = res.image[mask].astype(np.float64)
    b = ref.image[mask].astype(np.float64)
    mean = float(b.mean())
    rmse = float(np.sqrt(((a - b) ** 2).mean()))
    return rmse / mean if mean > 0 else rmse


def radiance_ratio(res, ref) -> float:
    """Mean linear radiance over the reference's geometry pixels, relative to the reference."""
    mask = ref.depth > 0
    b = float(ref.image[mask].astype(np.float64).mean()) if mask.any() else 0.0
    return float(res.image[mask].astype(np.float64).mean()) / b if b > 0 else 1.0


def fill_floor_positions(rows: list[dict]) -> None:
    """Each path row's shading time as a position between brute (0%) and the perfect
    culler's floor (100%) on the same frame."""
    by = {}
    for r in rows:
        if r["study"] == "path":
            by.setdefault((r["scene"], r["lights"], r["frame"]), {})[r["technique"]] = r
    for group in by.values():
        b, f = group.get(REFERENCE), group.get(PERFECT)
        if b is None or f is None:
            continue
        span = b["gpu_shade_ms"] - f["gpu_shade_ms"]
        for r in group.values():
            r["floor_position_pct"] = 100.0 * (b["gpu_shade_ms"] - r["gpu_shade_ms"]) / span \
                if span > 0 else math.nan


# ---------------------------------------------------------------------------- output

def _fmt(v) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return ""
        return f"{v:.4f}" if abs(v) < 1e6 else f"{v:.6g}"
    return str(v)


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({c: _fmt(r.get(c, "")) for c in COLUMNS})


def read_csv(path: Path) -> list[dict]:
    """Rows of results.csv with numbers parsed (empty cells: NaN)."""
    text_cols = {"study", "scene", "technique", "gpu_passes", "error_ref"}
    out = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            d = {}
            for k, v in r.items():
                if k in text_cols:
                    d[k] = v
                else:
                    try:
                        d[k] = float(v) if v != "" else math.nan
                    except ValueError:
                        d[k] = v
            out.append(d)
    return out


def machine_info() -> dict:
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info = {"cpu": model, "cores": os.cpu_count(), "python": platform.python_version(),
            "system": f"{platform.system()} {platform.release()}"}
    try:
        from . import gl
        lim = gl.limits()
        info.update(gl_renderer=lim.renderer, gl_version=lim.version, software=lim.software)
    except UserError as exc:
        info.update(gl_renderer=f"unavailable ({exc})", gl_version="", software=True)
    return info


def sweep_main(argv) -> None:
    p = cli.Parser(prog="python -m app.bench", description="the benchmark sweep and its report")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="reduced resolution and counts (default)")
    g.add_argument("--full", action="store_true", help="1920x1080, 8192..65536 lights, whole path")
    p.add_argument("--out", required=True, help="output folder (results.csv, report.md, PNGs)")
    p.add_argument("--size", type=cli.parse_size, help="override the preset's WxH")
    p.add_argument("--scenes", help="override: comma-separated builtin names or scene files")
    p.add_argument("--lights", help="override: comma-separated light counts")
    p.add_argument("--frames", type=int, help="override: frames along the camera path")
    p.add_argument("--repeat", type=int, help="override: repeats per configuration")
    p.add_argument("--cpu-lights", help="override: light counts of the CPU series")
    p.add_argument("--cpu-size", type=cli.parse_size, help="override: WxH of the CPU series")
    p.add_argument("--threads", type=int, help="numba threads of the CPU stage (default 1, "
                                               "as the paper's figure 4; 0: numba's default)")
    args = p.parse_args(argv)
    preset = preset_from_args(args)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    command = "python -m app.bench " + " ".join(argv)
    run_sweep(preset, out, command)


def _int_list(text: str, what: str) -> tuple[int, ...]:
    try:
        vals = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UserError(f"{what} must be comma-separated integers (got '{text}')") from None
    if not vals or min(vals) < 0:
        raise UserError(f"{what} must be non-negative integers (got '{text}')")
    return vals


def preset_from_args(args) -> Preset:
    preset = FULL if args.full else QUICK
    ch = {}
    if args.size:
        ch["size"] = tuple(args.size)
    if args.scenes:
        scenes = tuple(s.strip() for s in args.scenes.split(",") if s.strip())
        if not scenes:
            raise UserError("--scenes names no scene")
        ch.update(scenes=scenes, study_scene=scenes[0], heat_scene=scenes[-1],
                  cpu_scene=scenes[0], cutoff_scenes=scenes[:1])
    if args.lights:
        lights = _int_list(args.lights, "--lights")
        ch.update(lights=lights, study_lights=max(lights), cutoff_lights=min(lights))
    if args.frames is not None:
        if args.frames < 1:
            raise UserError("--frames must be >= 1")
        ch["frames"] = args.frames
    if args.repeat is not None:
        if args.repeat < 1:
            raise UserError("--repeat must be >= 1")
        ch.update(repeat=args.repeat, heavy_repeat=min(preset.heavy_repeat, args.repeat))
    if args.cpu_lights:
        ch["cpu_lights"] = _int_list(args.cpu_lights, "--cpu-lights")
    if args.cpu_size:
        ch["cpu_size"] = tuple(args.cpu_size)
    if args.threads is not None:
        if args.threads < 0:
            raise UserError("--threads must be >= 0")
        ch["cpu_threads"] = args.threads
    return replace(preset, **ch)


def run_sweep(preset: Preset, out: Path, command: str, log=sys.stderr) -> list[dict]:
    from . import report
    t0 = time.perf_counter()
    threads = set_cpu_threads(preset.cpu_threads)
    sweep = Sweep(preset, out, command, log)
    rows = sweep.run()
    write_csv(rows, out / "results.csv")
    np.savez_compressed(out / "maps.npz", **sweep.maps)
    elapsed = time.perf_counter() - t0
    info = dict(machine_info(), command=command, preset=preset.name, elapsed_s=elapsed,
                cpu_threads=threads,
                config={f.name: getattr(preset, f.name) for f in fields(preset)})
    (out / "run.json").write_text(json.dumps(info, indent=1, default=list) + "\n")
    report.write_report(out, read_csv(out / "results.csv"), dict(np.load(out / "maps.npz")), info)
    log.write(f"bench: wrote {out / 'results.csv'} ({len(rows)} rows) and {out / 'report.md'} "
              f"in {time.perf_counter() - t0:.0f} s\n")
    return rows


def main(argv=None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["cpu"]:
        cpu_main(argv[1:])
    else:
        sweep_main(argv)


if __name__ == "__main__":
    cli.run_main(lambda: main(sys.argv[1:]))
