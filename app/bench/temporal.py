"""Temporal stability along a moving path: `DIR/temporal.csv`.

Consecutive frames 0..F-1 of the scene's camera path (a loop of `loop` frames, so the camera
moves a little each frame) with its lights bouncing (scenes.motion, `--motion bounce`), each
frame rendered by

    every technique at its defaults            exact: the lab's guarantee (a sampler,
                                               role "sampler": an unbiased estimate,
                                               a new draw every frame, sample_frame = the
                                               frame index; its temporal error is its noise
                                               from frame to frame, kind "sampler")
    each cap policy (cpu_prep.caps)            on the first technique that takes one: a
                                               view policy drops the same lights whatever
                                               the structure (exact against brute without
                                               them); a per-tile one (HDRP FPTL) on the
                                               first whose list build applies it
    each light-cutoff level t = 1/c            the reference with the cutoff's radii
                                               (app.bench.cutoff.cutoff_lights)
    stochastic culling at each budget t = 1/N  the reference with Tokuyoshi & Harada's
      (app.bench.cutoff.STOCHASTIC_BUDGETS)    ranges, a new draw every frame
                                               (stochastic_frame = the frame index): what
                                               its noise costs from frame to frame
    the unbounded reference                    every light, UNBOUNDED_FALLOFF (no window)

and per frame k >= 1 and configuration T, against the unbounded reference R of the same
frames:

    temporal error   mean |dT - dR| over geometry pixels and channels, dX = X_k - X_(k-1),
                     relative to R_k's mean radiance (temporal_error_pct, percent)
    popping          pixels whose light set (contrib_hash) changed from k-1 to k while the
                     exact set there did not (the reference at the scene's radii, brute):
                     the set changed because a light crossed a cap or a cutoff, not because
                     it moved into or out of its volume (popping_pixels)

An exact technique's set is brute's at every pixel, so it never pops.  Each row also has the
frame's CPU stage (cpu_total_ms: the rebuild every frame costs) and frame cost.  A
stochastic configuration's popping counts the pixels whose drawn set changed where the exact
one did not: its noise, frame after frame (the estimate is unbiased, not steady).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import sys
import time

import numpy as np

from ..results import write_csv
from . import measure
from .cutoff import STOCHASTIC_BUDGETS, cutoff_lights, unbounded_lights
from .study import Study

# the series' file in the run's folder, as app.report.temporal.CSV reads it (not imported from
# there: the report's package imports GL, and the presets import this module for its config)
CSV = "temporal.csv"

COLUMNS = ["study", "scene", "lights", "width", "height", "frame", "frames", "motion_speed",
           "config", "kind", "technique", "role", "policy", "cutoff", "stochastic", "visible",
           "temporal_error_pct", "popping_pixels", "changed_pixels", "covered_pixels",
           "capped_lights", "cpu_total_ms", "frame_cost_ms", "wall_ms"]


def configurations(cutoffs, budgets=STOCHASTIC_BUDGETS) -> list[dict]:
    """Every configuration the series renders, the unbounded reference last."""
    from cpu_prep import caps
    from ..techniques import REGISTRY, with_role
    from ..techniques.options import CapOptions
    ref = with_role("reference")
    out = [dict(config=n, kind="sampler" if t.role == "sampler" else "technique", technique=n,
                opts=t.Options(), policy=caps.NONE, cutoff=0) for n, t in REGISTRY.items()]
    for p in (n for n in caps.NAMES if n != caps.NONE):
        capped = next((t for t in REGISTRY.values() if issubclass(t.Options, CapOptions)
                       and (t.Options.tile_caps or not caps.per_tile(p))), None)
        if capped is not None:
            out.append(dict(config=f"{p} ({capped.name})", kind="cap", technique=capped.name,
                            opts=capped.Options.make({"cap_policy": p}), policy=p, cutoff=0))
    out += [dict(config=f"cutoff 1/{c}", kind="cutoff", technique=ref.name, opts=ref.Options(),
                 policy=caps.NONE, cutoff=int(c)) for c in cutoffs]
    out += [dict(config=f"stochastic 1/{n}", kind="stochastic", technique=ref.name,
                 opts=ref.Options.make({"stochastic": int(n)}), policy=caps.NONE, cutoff=0)
            for n in budgets]
    out.append(dict(config="unbounded", kind="reference", technique=ref.name, opts=ref.Options(),
                    policy=caps.NONE, cutoff=-1))
    return out


def run_temporal(scene, scene_name: str, size, frames: int, loop: int, cutoffs,
                 log=None) -> list[dict]:
    """The series' rows: one per configuration and frame (frame 0 has no temporal figures)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..pipeline.renderer import Renderer
    from ..techniques import REGISTRY, with_role
    ref_name = with_role("reference").name
    configs = configurations(cutoffs)
    rows: list[dict] = []
    prev: dict = {}
    speed = float(scene.motion.speed) if scene.motion is not None else 0.0
    t0 = time.perf_counter()
    with Renderer(scene, tuple(size)) as r:
        def render(c, k, readback=True):
            lights = scene.lights_at(k, loop)
            defines = None
            if c["cutoff"] > 0:
                lights = cutoff_lights(lights, 1.0 / c["cutoff"])
            elif c["cutoff"] < 0:
                lights, defines = unbounded_lights(lights, scene), {"UNBOUNDED_FALLOFF": 1}
            opts = c["opts"].with_(stochastic_frame=k) if c["kind"] == "stochastic" else \
                c["opts"].with_(sample_frame=k) if c["kind"] == "sampler" else c["opts"]
            return r.render(REGISTRY[c["technique"]], k, opts, frames=loop, lights=lights,
                            readback=readback, defines=defines)
        warm = {(c["technique"], c["kind"]): c for c in configs}   # each program variant once
        for c in warm.values():                                     # compilation, not measured
            render(c, 0, readback=False)
        for k in range(frames):
            w0 = time.perf_counter()
            res = {}
            for c in configs:
                s0 = time.perf_counter()
                res[c["config"]] = (render(c, k), (time.perf_counter() - s0) * 1e3)
            exact = res[ref_name][0]
            unb = res["unbounded"][0]
            covered = exact.depth > 0
            for c in configs:
                f, wall = res[c["config"]]
                rows.append(_row(c, k, f, wall, prev.get(c["config"]), unb, prev.get("unbounded"),
                                 exact, prev.get(ref_name), covered, scene_name, len(scene.lights),
                                 size, loop, speed))
            prev = {n: v[0] for n, v in res.items()}
            log.write(f"[temporal {k + 1}/{frames} {time.perf_counter() - t0:6.1f}s] frame {k}: "
                      f"{len(configs)} configurations in {time.perf_counter() - w0:.1f} s\n")
            log.flush()
    return rows


def _row(c, k, f, wall, f_prev, unb, unb_prev, exact, exact_prev, covered, scene_name, n,
         size, loop, speed) -> dict:
    from ..techniques import REGISTRY
    tech = REGISTRY[c["technique"]]
    sample = measure.samples_of(f.meta)[0]
    stats = f.meta["stats"]
    row = {"study": "temporal", "scene": scene_name, "lights": n, "width": size[0],
           "height": size[1], "frame": k, "frames": loop, "motion_speed": speed,
           "config": c["config"], "kind": c["kind"], "technique": tech.name, "role": tech.role,
           "policy": c["policy"], "cutoff": c["cutoff"],
           "stochastic": int(getattr(c["opts"], "stochastic", 0)),
           "visible": int(stats.get("visible_lights", 0)),
           "capped_lights": int(stats.get("capped_lights", 0)),
           "covered_pixels": int(covered.sum()),
           "cpu_total_ms": float(sum(sample["cpu_ms"].values())),
           "frame_cost_ms": measure.frame_cost(sample), "wall_ms": wall,
           "temporal_error_pct": float("nan"), "popping_pixels": float("nan"),
           "changed_pixels": float("nan")}
    if f_prev is not None:
        row.update(temporal_figures(f, f_prev, unb, unb_prev, exact, exact_prev, covered))
        if c["kind"] == "reference":        # every light, no volume: its sets are no measure
            row["popping_pixels"] = row["changed_pixels"] = float("nan")
    return row


def temporal_figures(f, f_prev, ref, ref_prev, exact, exact_prev, covered) -> dict:
    """temporal_error_pct, popping_pixels and changed_pixels of frame f after f_prev (module
    docstring), against the unbounded reference `ref` and the exact sets of `exact`."""
    dt = f.image.astype(np.float64) - f_prev.image.astype(np.float64)
    dr = ref.image.astype(np.float64) - ref_prev.image.astype(np.float64)
    mean = float(ref.image[covered].astype(np.float64).mean()) if covered.any() else 0.0
    err = float(np.abs(dt - dr)[covered].mean()) if covered.any() else 0.0
    changed = f.contrib_hash != f_prev.contrib_hash
    steady = exact.contrib_hash == exact_prev.contrib_hash
    return {"temporal_error_pct": 100.0 * err / mean if mean > 0 else 100.0 * err,
            "changed_pixels": int((changed & covered).sum()),
            "popping_pixels": int((changed & steady & covered).sum())}


def temporal_series(c: "TemporalConfig", out: Path, log=None) -> list[dict]:
    """The series of `c` into out/temporal.csv; none when it has fewer than two frames (a
    stale file is removed, so no report shows it)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from scenes import load_scene
    from scenes.motion import with_motion
    out = Path(out)
    path = out / CSV
    if c.frames < 2:
        path.unlink(missing_ok=True)
        return []
    out.mkdir(parents=True, exist_ok=True)
    scene = with_motion(load_scene(c.scene, lights=c.lights, seed=c.seed), "bounce")
    rows = run_temporal(scene, c.scene, c.size, c.frames, c.loop, c.cutoffs, log)
    write_csv(rows, path, COLUMNS)
    log.write(f"bench: wrote {path} ({len(rows)} rows)\n")
    return rows


@dataclass(frozen=True)
class TemporalConfig:
    """The series' settings: frames 0..frames-1 of a loop-frame loop of the scene's path
    with its lights bouncing, every technique, cap policy and cutoff level against the
    unbounded reference; frames < 2: none."""
    frames: int
    loop: int = 600
    scene: str = "arena"
    lights: int = 2048
    size: tuple[int, int] = (128, 72)
    cutoffs: tuple[int, ...] = (256, 4096, 65536)
    seed: int = 0


class TemporalStudy(Study):
    """The sweep's first study: out/temporal.csv (the report's temporal section reads it),
    none of results.csv's rows.  It runs on numba's default threads, as it did when it ran
    before the sweep set the CPU stage's thread count."""
    name = "temporal"
    files = (CSV,)
    sections = ("temporal", "tradeoff", "path")
    Config = TemporalConfig

    def run(self, out, sweep) -> list[dict]:
        import numba
        before = numba.get_num_threads()
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        try:
            temporal_series(self.config, Path(out), sweep.log)
        finally:
            numba.set_num_threads(before)
        return []


__all__ = ["run_temporal", "temporal_series", "temporal_figures", "configurations",
           "TemporalConfig", "TemporalStudy", "COLUMNS", "CSV"]
