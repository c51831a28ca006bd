"""`python -m app.bench [--quick|--full] --out DIR`: the sweep.  Renders every job of the
plan (app.bench.plan) through Renderer.render like any frame, takes the timing samples with
render(samples=N), checks every frame against the reference's (the rendered study), runs
the preset's other studies (app.bench.study; presets.STUDY_ORDER), and writes
DIR/results.csv (app.results), DIR/maps.npz, DIR/run.json and the report.

Timing: every configuration is rendered once with read-back (counters, image, and, while
its buffers are there, the wave replay and the GPU cost model: app.model); then its timing
samples are taken.  A configuration whose frame an earlier study of the scene read back (an
option study's default value is the path's frame 0) takes that render's cells and its own
timing samples.  The first render of a configuration's programs in the process is
a warm-up (shader and numba compilation) whose timing is discarded; later ones count as a
sample.  A configuration whose loop evaluates more than `heavy_eval_pp` lights a pixel gets
`heavy_repeat` samples, one of an option study (a single frame) `study_repeat`.  The sample
counts depend only on the command.

Samples are interleaved: the configurations that are compared with each other (one group:
the same study, scene, light count and frame, every technique and option value of it) take
their samples in rounds, one render of each configuration a round.  Taken back to back, a
configuration's samples would share the machine's state of that moment (a busy core, a
clock), and a drift between two configurations would pass for a difference beyond their
spread; interleaved, both see the same drift, so each one's min-max holds it.  So every
sample is a whole frame (G-buffer, CPU stage, untimed set-up passes and host steps, timed
passes), since the configurations in between overwrite the set-up's buffers; only the CPU
stage and the timed passes are measured, as before, and the steps that only count figures
(figures=True, app.pipeline.passes) run in the read-back render alone.  The log names each
configuration as its read-back render starts, then the group's rounds of samples.
"""
from __future__ import annotations

import argparse
from dataclasses import replace
from itertools import groupby
import json
from pathlib import Path
import sys
import time

import numpy as np

from .. import cli
from ..results import columns, option_studies, read_csv, write_csv
from ..techniques import REGISTRY, with_role
from ..techniques.options import STOCHASTIC_NAMES
from . import measure
from .caps import CAPS, loss_cells, with_caps_jobs
from .cpu import set_cpu_threads
from .cutoff import cutoff_lights, stochastic_draw, unbounded_lights
from .machine import machine_info
from .plan import Job, plan, study_scene
from .presets import Preset, preset_from_args
from .study import STUDIES, Study, time_lines, timed


class Sweep:
    """What the studies share (the preset's Shared config, the log, the progress line, the
    scenes loaded) and the rendered study's measuring; `rendered`: that study's config
    (render_jobs sets it; the preset's until then)."""
    def __init__(self, preset: Preset, log=None, motion: str | None = None):
        log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
        self.name = preset.name
        self.shared = preset.shared
        self.rendered = preset.config("rendered")
        self.log = log
        self.motion = motion          # --motion (scenes.motion.with_motion; None: the scene's own)
        self.rows: list[dict] = []
        self.maps: dict[str, np.ndarray] = {}
        self.warm: set = set()
        # (scene, lights, frame, cutoff, stochastic draw) -> the reference's FrameResult
        self.refs: dict = {}
        self.read_back: dict = {}     # frame_key -> (row cells of its read-back render, heavy)
        self.light_sets: dict = {}    # (scene, lights, cutoff) -> light array
        self.scenes: dict = {}
        self.reference = with_role("reference").name
        self.floor = with_role("floor").name
        self.serial = 0               # the renderer in use (its programs are compiled anew)
        self.t0 = time.perf_counter()

    # ---- scenes and lights ----------------------------------------------------------------

    def scene(self, name: str, lights: int):
        from scenes import BUILTIN_SCENES, load_scene
        from scenes.motion import with_motion
        key = (name, lights)
        if key not in self.scenes:
            n = lights if name in BUILTIN_SCENES else None
            # a scene file takes no seed (its lights are its own); its motion moves them, as
            # in capture, unless --motion says otherwise
            seed = self.shared.seed if name in BUILTIN_SCENES else 0
            self.scenes[key] = with_motion(load_scene(name, lights=n, seed=seed), self.motion)
        return self.scenes[key]

    def light_counts(self, name: str, counts) -> tuple[int, ...]:
        from scenes import BUILTIN_SCENES
        if name in BUILTIN_SCENES:
            return tuple(counts)
        return (len(self.scene(name, 0).lights),)   # a scene file: its own lights

    def lights_for(self, job: Job):
        """The job's lights: the scene's at the job's frame of the path loop (moved by its
        motion, Scene.lights_at, as capture's frame K of --frames F), with the job's cutoff."""
        sc = self.scene(job.scene, job.lights)
        moving = sc.motion is not None and sc.motion.speed != 0
        lights = sc.lights_at(job.frame, self.shared.frames)
        if job.cutoff == 0:
            return lights
        key = (job.scene, job.lights, job.cutoff, job.frame if moving else 0)
        if key not in self.light_sets:
            self.light_sets[key] = (unbounded_lights(lights, sc) if job.cutoff < 0
                                    else cutoff_lights(lights, 1.0 / job.cutoff))
        return self.light_sets[key]

    # ---- measuring -------------------------------------------------------------------------

    def progress(self, i: int, total: int, what: str) -> None:
        self.log.write(f"[{i}/{total} {time.perf_counter() - self.t0:6.1f}s] {what}\n")
        self.log.flush()

    def render(self, renderer, job: Job, readback: bool, samples: int = 1):
        defines = {"UNBOUNDED_FALLOFF": 1} if job.cutoff < 0 else None
        # keep_setup: a timing sample reruns the untimed set-up (the floor's exact lists, the
        # rasterized proxies, ...) only where a configuration between overwrote it
        return renderer.render(REGISTRY[job.technique], job.frame, job.opts,
                               frames=self.shared.frames, lights=self.lights_for(job),
                               readback=readback, defines=defines, samples=samples,
                               keep_setup=True)

    def reference_frame(self, renderer, job: Job, cutoff: int):
        """The reference's frame for the job's scene, lights, frame and `cutoff` (and the
        job's stochastic draw, but for the unbounded reference)."""
        draw = stochastic_draw(job.opts) if cutoff >= 0 else ()
        key = (job.scene, job.lights, job.frame, cutoff, draw)
        if key not in self.refs:
            ref = REGISTRY[self.reference]
            opts = ref.Options.make(dict(zip(STOCHASTIC_NAMES, draw)))
            ref_job = replace(job, technique=ref.name, opts=opts, cutoff=cutoff)
            self.refs[key] = self.render(renderer, ref_job, True)
        return self.refs[key]

    def first_render(self, renderer, job: Job):
        """(row without its timing cells, timing samples it already holds, samples it
        wants): the configuration's read-back render, which counts as a sample when its
        programs were compiled before (module docstring), and its maps (kept while the
        renderer still holds its frame).  A configuration read back before in this scene
        (an option study's default is the path's frame 0) takes that render's cells: the same
        frame gives the same figures, checks and model; its timing samples are its own."""
        frame = self.frame_key(job)
        same = self.read_back.get(frame)
        if same is not None:
            row, heavy = same
            return dict(row, study=job.study), [], self.wanted(job, heavy)
        res = self.render(renderer, job, True)
        self.keep_maps(job, res, renderer)
        model = self.model_cells(renderer, job, res) if self.modelled(job) else {}
        types = tuple(np.unique(self.lights_for(job)["type"]).tolist())   # shader features
        key = (self.serial, job.technique, job.opts, job.cutoff < 0, types)
        samples = measure.samples_of(res.meta) if key in self.warm else []
        self.warm.add(key)
        heavy = measure.evaluated_per_pixel(res) > self.rendered.heavy_eval_pp
        if job.technique == self.reference:
            ref_key = (job.scene, job.lights, job.frame, job.cutoff, stochastic_draw(job.opts))
            self.refs[ref_key] = res
        row = self.row(job, res, renderer)
        row.update(model)
        if frame is not None:
            self.read_back[frame] = (dict(row), heavy)
        return row, samples, self.wanted(job, heavy)

    def modelled(self, job: Job) -> bool:
        """Whether the configuration's row gets the modelled columns (its wave replay): every
        row but the path frames past the rendered config's model_frames and the rows of its
        unmodelled studies."""
        n = self.rendered.model_frames
        if job.study in self.rendered.unmodelled:
            return False
        return job.study != "path" or not n or job.frame < n

    def wanted(self, job: Job, heavy: bool) -> int:
        """The timing samples a configuration takes (module docstring)."""
        return self.rendered.heavy_repeat if heavy else \
            self.shared.repeat if job.study in ("path", "cutoff") else self.rendered.study_repeat

    def frame_key(self, job: Job):
        """What makes a configuration's frame and row cells (but its study and timings) on
        the renderer in use, whether the row is modelled included: None for the cutoff and
        caps studies, whose errors and losses are their own."""
        if job.study in ("cutoff", CAPS):
            return None
        return (self.serial, job.scene, job.lights, job.frame, job.technique, job.opts,
                job.cutoff, self.modelled(job))

    def model_cells(self, renderer, job: Job, res) -> dict:
        """The modelled GPU columns of a frame the renderer still holds (app.model)."""
        from ..model import predict        # GL: not at import (the command's parser has it)
        return measure.model_cells(predict.modelled_or_none(
            renderer, REGISTRY[job.technique], res, job.opts, unbounded=job.cutoff < 0,
            budget=self.rendered.replay_budget, segments=self.rendered.replay_segments))

    def measure_group(self, renderer, group: list[Job], first: int, total: int) -> None:
        """Rows of a group of configurations compared with each other: each one's read-back
        render (and its maps), then the timing samples in interleaved rounds."""
        pending = []
        for k, job in enumerate(group):
            again = " (its frame read back before)" if self.frame_key(job) in self.read_back else ""
            self.progress(first + k, total, job.describe() + again)
            renderer.scene = self.scene(job.scene, job.lights)   # same geometry, these lights
            pending.append((job, *self.first_render(renderer, job)))
        rounds = max((want - len(samples) for _, _, samples, want in pending), default=0)
        if rounds > 0:
            self.log.write(f"  timing: {rounds} interleaved round(s) of the {len(pending)} above\n")
            self.log.flush()
        for _ in range(rounds):
            for job, row, samples, want in pending:
                if len(samples) < want:
                    renderer.scene = self.scene(job.scene, job.lights)
                    samples += measure.samples_of(self.render(renderer, job, False).meta)
        for job, row, samples, _ in pending:
            row.update(measure.timing_cells(samples))
            row.update(measure.model_frame_cells(row))
            self.rows.append(row)

    def row(self, job: Job, res, renderer) -> dict:
        """A row's cells but the timing ones (measure_group adds them)."""
        w, h = renderer.size
        tech = REGISTRY[job.technique]
        r = {"study": job.study, "scene": job.scene, "lights": job.lights,
             "visible": int(res.meta["stats"].get("visible_lights", 0)), "width": w, "height": h,
             "frame": job.frame, "frames": self.shared.frames, "technique": tech.name,
             "role": tech.role, "cutoff": job.cutoff}
        r.update(measure.option_cells(job.opts))
        r.update(measure.figure_cells(res))
        r["setup_ms"] = float(sum(res.meta.get("setup_ms", {}).values()))    # no cost: untimed
        # the error of a cutoff or caps job is against the unbounded reference, its exactness
        # against the reference with the same lights (a capped frame's: app.bench.caps)
        unbounded = job.study in ("cutoff", CAPS)
        err_ref = self.reference_frame(renderer, job, -1 if unbounded else job.cutoff)
        r["error_ref"] = "unbounded" if unbounded else self.reference
        r["image_error"] = measure.image_error(res, err_ref)
        r["image_flip"] = measure.image_flip(res, err_ref)
        r["radiance_ratio"] = measure.radiance_ratio(res, err_ref)
        if job.cutoff < 0:
            r["mismatch_count"] = r["mismatch_hash"] = 0
        else:
            ref = self.reference_frame(renderer, job, job.cutoff)
            r["mismatch_count"], r["mismatch_hash"] = measure.mismatches(res, ref)
            if job.study == CAPS:
                r.update(loss_cells(renderer, res, ref, r["stats"], dict(
                    frame=job.frame, frames=self.shared.frames, lights=self.lights_for(job),
                    opts=job.opts)))
        r["floor_position_pct"] = float("nan")
        return r

    def keep_maps(self, job: Job, res, renderer=None) -> None:
        """Block maps of the heat-map frame (figures 1 and 3), and the maps of each
        technique's own structure (Technique.maps: own/<technique>/<name>, its label beside)."""
        from ..images import block_mean
        p = self.shared
        if not (job.study == "path" and job.scene == self.rendered.heat_scene and job.frame == 0
                and job.lights == max(self.light_counts(job.scene, p.lights))):
            return
        block = 8 if res.evaluated.shape[1] < 960 else 16
        self.maps["block"] = np.array(block)
        self.maps[f"evaluated/{job.technique}"] = block_mean(res.evaluated.astype(np.float64), block)
        self.maps[f"cases/{job.technique}"] = (res.wave["case_bits"] & 3).astype(np.uint8)
        if job.technique == self.reference:
            self.maps["exact"] = block_mean(res.contrib_count.astype(np.float64), block)
        if renderer is not None:
            from ..techniques import REGISTRY
            try:         # the renderer still holds this technique's frame (first_render)
                own = REGISTRY[job.technique].maps(res, renderer.read)
            except KeyError:
                own = {}
            for name, (values, label) in own.items():
                self.maps[f"own/{job.technique}/{name}"] = np.asarray(values)
                self.maps[f"ownlabel/{job.technique}/{name}"] = np.array(label)

    def render_jobs(self, c) -> list[dict]:
        """The rendered study of config `c` (app.bench.rendered): every job of the plan and
        the caps series, scene by scene, with the floor positions filled; its rows (also
        kept in self.rows)."""
        from ..pipeline.renderer import Renderer
        self.rendered = c
        first = len(self.rows)
        jobs = with_caps_jobs(plan(c, self.light_counts), c, self.light_counts,
                              self.scene, self.log)
        total = len(jobs)
        studies = option_studies()
        self.log.write(f"bench: {self.name} preset, {total} configurations + CPU series; "
                       f"option studies: " + "; ".join(f"{k} ({', '.join(v[1])})"
                                                     for k, v in studies.items()) + "\n")
        renderer, current, i = None, None, 1
        try:
            for group in compared_groups(jobs):
                job = group[0]
                if job.scene != current:
                    if renderer is not None:
                        renderer.release()
                    self.refs.clear()
                    self.read_back.clear()
                    self.light_sets.clear()
                    renderer = Renderer(self.scene(job.scene, job.lights), self.shared.size)
                    self.serial += 1
                    current = job.scene
                self.measure_group(renderer, group, i, total)
                i += len(group)
                self._forget(group[-1])
        finally:
            if renderer is not None:
                renderer.release()
        rows = self.rows[first:]
        measure.fill_floor_positions(rows, self.reference, self.floor)
        return rows

    def _forget(self, job: Job) -> None:
        """Drop references no later job needs (full-resolution frames are ~50 MB each)."""
        p = self.shared
        studies = {study_scene(p, spec) for spec, _ in option_studies().values()}
        for key in list(self.refs):
            scene, n, frame, cut, draw = key
            keep = (scene == job.scene and n == job.lights and frame == job.frame) or \
                   (scene in studies and frame == 0 and cut == 0 and not draw and
                    n == self.light_counts(scene, (p.study_lights,))[0])
            if not keep:
                del self.refs[key]


def preset_studies(preset: Preset) -> list[Study]:
    """The preset as its studies, each with its config, in the order they run (and their
    rows stand in results.csv); the presets module imported every study's module."""
    return [STUDIES[name](config) for name, config in preset.studies]


# ---------------------------------------------------------------------------- the command

def compared_groups(jobs: list[Job]) -> list[list[Job]]:
    """Consecutive jobs of one study, scene, light count and frame: the configurations whose
    timings are compared with each other (their samples are interleaved)."""
    return [list(g) for _, g in groupby(jobs, key=lambda j: (j.study, j.scene, j.lights, j.frame))]


def run_sweep(preset: Preset, out: Path, command: str, log=None,
              motion: str | None = None) -> list[dict]:
    """Run the preset's studies, write out/results.csv, maps.npz, run.json and the report
    (`motion`: --motion, the lights' motion; None: each scene's own); end with where the
    time went, a line a study and the report's (also run.json's study_s and report_s), each
    study's by phase (run.json's phase_s: app.pipeline.phases)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from .. import report
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    threads = set_cpu_threads(preset.shared.threads)
    sweep = Sweep(preset, log, motion)
    by_phase: dict = {}
    rows, seconds = timed(preset_studies(preset), out, sweep, by_phase)
    write_csv(rows, out / "results.csv", columns())
    np.savez_compressed(out / "maps.npz", **sweep.maps)
    elapsed = time.perf_counter() - t0
    info = dict(machine_info(), command=command, preset=preset.name, elapsed_s=elapsed,
                cpu_threads=threads, motion=motion or "the scenes' own",
                config=preset.as_dict(),
                study_s={k: round(v, 3) for k, v in seconds.items()},
                phase_s={k: {p: round(v, 3) for p, v in ph.items()} for k, ph in by_phase.items()})
    (out / "run.json").write_text(json.dumps(info, indent=1, default=list) + "\n")
    t1 = time.perf_counter()
    report.write_report(out, read_csv(out / "results.csv"), dict(np.load(out / "maps.npz")), info)
    seconds["report"] = time.perf_counter() - t1
    info["report_s"] = round(seconds["report"], 3)       # known once the report is written
    (out / "run.json").write_text(json.dumps(info, indent=1, default=list) + "\n")
    log.write(f"bench: wrote {out / 'results.csv'} ({len(rows)} rows) and {out / 'report.md'} "
              f"in {time.perf_counter() - t0:.0f} s\n")
    log.write("".join(line + "\n" for line in time_lines(seconds, by_phase)))
    return rows


def add_args(p) -> None:
    """The sweep's flags (on the command's own parser: the sweep is its default)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quick", action="store_true", help="reduced resolution and counts (default)")
    g.add_argument("--full", action="store_true", help="1920x1080, 8192..65536 lights, whole path")
    g.add_argument("--gpu-check", action="store_true",
                   help="for a real GPU (scripts/gpu_check.sh): 1920x1080, every technique, arena "
                        "and city at 8192 and 65536 lights, one path frame, measured against modelled")
    p.add_argument("--out", help="output folder (results.csv, report.md, PNGs; required)")
    p.add_argument("--size", type=cli.parse_size, help="override the preset's WxH")
    p.add_argument("--scenes", help="override: comma-separated builtin names or scene files")
    p.add_argument("--lights", help="override: comma-separated light counts")
    p.add_argument("--frames", type=int, help="override: frames along the camera path")
    p.add_argument("--repeat", type=int,
                   help="override: timing samples per configuration (option studies included)")
    p.add_argument("--cpu-lights", help="override: light counts of the CPU series")
    p.add_argument("--cpu-size", type=cli.parse_size, help="override: WxH of the CPU series")
    p.add_argument("--growth-lights", help="override: light counts of the CPU stage's growth "
                                           "series (quick and full: 8,192 doubling to 1,048,576; "
                                           "0: none)")
    p.add_argument("--gpu-build-lights", help="override: light counts of the CPU / GPU build "
                                              "comparison (quick: 4096,16384; full: 8192,32768,"
                                              "131072; 0: none)")
    p.add_argument("--c-reference-lights", help="override: light counts of the CPU stage "
                                                "against the plain C reference (quick: 65536; "
                                                "full: 16384,65536; 0: none)")
    p.add_argument("--temporal-frames", type=int,
                   help="override: frames of the temporal stability series (quick: 6; full: 16; "
                        "0: none)")
    p.add_argument("--threads", type=int, help="numba threads of the CPU stage (default 1, "
                                               "as the paper's figure 4; 0: numba's default)")
    p.add_argument("--papers", action=argparse.BooleanOptionalAction, default=None,
                   help="the papers' settings at 1920x1080, modelled (default: on, off with "
                        "--scenes)")
    cli.add_motion_arg(p)


def run(args, argv) -> None:
    """The sweep of the parsed command line `args` (`argv`: its words, for run.json)."""
    preset = preset_from_args(args)
    command = "python -m app.bench " + " ".join(argv)
    run_sweep(preset, Path(args.out), command, motion=args.motion)


def sweep_main(argv) -> None:
    """`python -m app.bench [--quick|--full] --out DIR ...`: the sweep."""
    from . import main
    main(list(argv))
