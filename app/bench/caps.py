"""The engines' light caps as a bench series: what a cap policy
(cpu_prep.caps, `--cap-policy`) saves in frame cost and loses in image, measured beside the
light cutoff study's levels (the report's lead figure, app.report.tradeoff).

    each list technique (every technique whose Options take cap_policy)
      x  none, and each view policy that drops lights from the scene's visible ones
    fptl (every technique whose list build takes the per-tile caps, Options.tile_caps)
      x  each per-tile policy (HDRP FPTL 24 / 63: whether a tile passes its cap is known
         only from the GPU's lists, so they always run; the row says what they dropped)
    in the rendered study's caps_scenes at its caps_lights (app.bench.rendered: the cutoff
    study's light count, so the figure holds both), frame 0, the scene's own radii

Rows of study "caps" in results.csv's schema (app.results), measured as the sweep measures
every configuration (app.bench.sweep: a read-back render, then interleaved timing samples,
study_repeat of them), with

    image_error, image_flip,   against the cutoff study's unbounded reference (every light,
      radiance_ratio           UNBOUNDED_FALLOFF, app.bench.cutoff.unbounded_lights; the
                               sweep's own reference frame); error_ref "unbounded"
    mismatch_count, _hash      the exactness check's (app.exactness.check): a capped frame
                               against brute without the lights its policy dropped (0: the
                               technique found every kept light; otherwise the differing
                               pixels in both), an uncapped one against brute
    stats                      the frame's stats (capped_lights) and its intended loss
                               against brute: lost_pixels (pixels whose light set differs)
                               and lost_contributions ((pixel, light) pairs lost); 0 for none;
                               a per-tile cap also lost_entries and lost_tiles

A view policy whose every budget holds its group's visible lights drops nothing: its frame
is none's, so it is skipped, and the log says so.
"""
from __future__ import annotations

import json

import numpy as np

from cpu_prep import caps

from ..pipeline import phases

CAPS = "caps"                  # results.csv study of the series


def cap_techniques(policy: str = caps.NONE) -> list[str]:
    """The techniques that take the cap policy `policy` (a per-tile one: those whose list
    build applies it), in registry order."""
    from ..techniques import REGISTRY
    from ..techniques.options import CapOptions
    return [n for n, t in REGISTRY.items() if issubclass(t.Options, CapOptions)
            and (t.Options.tile_caps or not caps.per_tile(policy))]


def dropped_lights(scene, size, frame: int, frames: int) -> dict[str, int]:
    """{policy: visible lights it drops} at the scene's `frame` (the CPU cull every
    technique shares, cpu_prep.frame; no GL)."""
    from cpu_prep.arena import Arena
    from cpu_prep.camera import frame_camera
    from cpu_prep.frame import StageTimes, prepare_capped_lights
    cam = frame_camera(scene.camera_at(frame, frames), *size)
    return {p: len(prepare_capped_lights(scene.lights, cam, StageTimes(), 0, Arena(), p)[1])
            for p in caps.NAMES}


def caps_jobs(p, scene_name: str, lights: int, scene, log=None) -> list:
    """The series' jobs in one scene: every cap technique at none and at each view policy
    that drops a light (the skipped ones named in `log`), the per-tile policies on the
    techniques that take them."""
    from ..techniques import REGISTRY
    from .plan import Job
    dropped = dropped_lights(scene, p.shared.size, 0, p.shared.frames)
    biting = [k for k, name in enumerate(caps.NAMES)
              if name == caps.NONE or dropped[name] or caps.per_tile(name)]
    skipped = [n for n in caps.NAMES if n != caps.NONE and not dropped[n] and not caps.per_tile(n)]
    if skipped and log is not None:
        log.write(f"bench: caps in {scene_name} at {lights} lights: {', '.join(skipped)} drop "
                  f"nothing (every budget holds the visible lights): skipped\n")
    return [Job(CAPS, scene_name, lights, 0, t, REGISTRY[t].Options().with_(cap_policy=k))
            for k in biting for t in cap_techniques(caps.NAMES[k])]


def with_caps_jobs(jobs: list, p, light_counts, scene_of, log=None) -> list:
    """`jobs` (the plan's) with the series' jobs of each caps scene after that scene's last
    job (its renderer, and the unbounded reference the cutoff study rendered, still held)."""
    out = list(jobs)
    for name in (s for s in p.caps_scenes if s in p.shared.scenes):
        n = light_counts(name, (p.caps_lights,))[0]
        last = max((i for i, j in enumerate(out) if j.scene == name), default=len(out) - 1)
        out[last + 1:last + 1] = caps_jobs(p, name, n, scene_of(name, n), log)
    return out


@phases.timed("check")            # app.pipeline.phases: where a run's time goes
def loss_cells(renderer, res, ref, stats: str, render_args: dict) -> dict:
    """A caps row's exactness and intended loss (module docstring): mismatch_count,
    mismatch_hash and the stats JSON `stats` with lost_pixels and lost_contributions, from
    the frame `res` and brute's frame `ref` of the same lights (render_args: the frame's
    frame, frames, lights and opts, as app.exactness.check takes them)."""
    from .. import exactness
    from ..techniques import REGISTRY, with_role
    from . import measure
    cells = dict(json.loads(stats or "{}"), lost_pixels=0, lost_contributions=0)
    if exactness.capped(res) is None:
        out = dict(zip(("mismatch_count", "mismatch_hash"), measure.mismatches(res, ref)))
    else:
        got = exactness.check(res, ref, renderer, REGISTRY[res.meta["technique"]],
                              with_role("reference"), render_args)
        if isinstance(got, exactness.IntendedLoss):
            out = {"mismatch_count": 0, "mismatch_hash": 0}
            cells.update(lost_pixels=got.pixels, lost_contributions=got.contributions)
            if got.entries is not None:
                cells.update(lost_entries=got.entries, lost_tiles=got.tiles)
        else:                          # not exact on the lights it kept: a plain failure
            out = {"mismatch_count": got.pixels, "mismatch_hash": got.pixels}
            cells.update(lost_pixels=int(exactness.differing(res, ref).sum()),
                         lost_contributions=int(np.maximum(ref.contrib_count.astype(np.int64) -
                                                           res.contrib_count, 0).sum()))
    out["stats"] = json.dumps(cells, sort_keys=True)
    return out


__all__ = ["CAPS", "cap_techniques", "dropped_lights", "caps_jobs", "with_caps_jobs", "loss_cells"]
