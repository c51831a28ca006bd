"""Sampling against culling on one frame: `DIR/sampling.csv`.

A sampler (every technique of role "sampler") shades S drawn lights a pixel and weights them
so that its image is an unbiased estimate of brute's; a culling technique shades the lights
its structure keeps.  On one frame (frame 0 of each scene's path, the scene's own radii)
the study renders

    every technique of another role     exact: its image is brute's (error 0)
    each engine cap policy              on the first technique that takes one (a view
      (cpu_prep.caps, --cap-policy)     policy drops the same lights whatever the
                                        structure; skipped where it drops none), a
                                        per-tile one on the first whose build applies it
    every sampler at each S             K seeds (sample_seed 0..K-1, sample_frame 0)

and writes a row a configuration (COLUMNS), against brute's frame (the reference role):

    image_error        relative RMSE of linear radiance over geometry pixels (measure.
                       image_error); a sampler's median over its seeds, with _min / _max
    image_flip         mean LDR FLIP of the tone-mapped images (measure.image_flip), idem
    seed_errors        every seed's image_error, JSON
    evaluated_pp       light evaluations a geometry pixel (mean of `evaluated`)
    evaluated_lit_pp   the same over pixels some light affects (brute's contrib_count > 0):
                       S for sample-list, whose cell there holds that light
    shadow_pp          shadow tests a geometry pixel: a culling configuration tests each
                       light that affects the pixel (its own contrib_count); a sampler each
                       draw that hits a light affecting the pixel, counted by its wave
                       replay (the GPU's draws made again on the CPU, the first seed's);
                       without a replay (sample-ris with spatial reuse) at most each draw
                       at a pixel some light affects (shadow_bound 1: an upper bound)
    frame cost         cpu_total_ms, gpu_lighting_ms, frame_cost_ms (+ _min / _max) over
                       the timing samples as the rendered study measures them (measure.
                       timing_cells): a sampler's K seed renders, another's `repeat`;
                       interleaved in rounds, one render of each configuration a round
    model_<gpu>_*_ms   the modelled lighting and frame (app.model) where the frame has a
                       wave replay; blank where it has none (no number is invented)
    bins               per light-count bin, JSON {lo, hi, pixels, geometry, err}: geometry
                       pixels binned by brute's contrib_count in [2^k, 2^(k+1)) (pixels no
                       light affects left out: every configuration is exact there), the
                       geometry pixels of the frame, and each seed's RMSE over the bin's
                       pixels divided by brute's mean radiance over the whole frame (the
                       frame error's own scale)
    mismatch_count     pixels whose contrib_count / hash differ from brute's: 0 for exact
                       techniques and for a sampler's support; a cap's intended loss

The crossover (app.report.sampling.crossover, from these rows alone): on each frame, the
named cap is the cap policy of least nonzero image_error that the sampler's median frame
error reaches at some measured S (the mildest that loses light and whose error sampling
matches inside the study), else the one of least nonzero image_error.  E_S(n), the frame error of sampling at S only the pixels that at most n lights
affect (brute's radiance elsewhere), is sqrt(sum over the bins up to n of pixels x err^2 /
geometry) on the frame error's scale, growing with n to the sampler's whole frame error.
For each S and seed, n(S) is the largest bin edge `hi` with E_S(n) at most the cap's frame
image_error (0: not even the first bin; "every bin": the sampler's whole frame is within
it); the sentence gives n's median [min, max] over seeds.  S* is where the sampler's frame
error equals the cap's: interpolated in log S / log error between the two study values of S
whose median error brackets it (from the min and max errors over seeds the range), or
"below S_min" / "beyond S_max"; S* is also given against every other cap that loses light, and by image_flip against the
named cap's.
Close: the measured S nearest S* holds the cap's error inside its min-max over seeds, or
not (a difference inside that spread is not a finding).  Culling configurations that estimate
another image (light cutoff levels, stochastic culling: the unbounded reference) are not
in this study: their target is not the sampler's.
"""
from __future__ import annotations

from dataclasses import dataclass
import json
from pathlib import Path
import sys
import time

import numpy as np

from . import measure
from .rendered import REPLAY_BUDGET
from .study import FileStudy, series_files, study_scene, write_series

CSV = "sampling.csv"           # read by app.report.sampling (not imported from there: GL)

COLUMNS = ["study", "scene", "lights", "visible", "width", "height", "frame", "config", "kind",
           "technique", "role", "policy", "samples_per_pixel", "seeds", "image_error",
           "image_error_min", "image_error_max", "image_flip", "image_flip_min", "image_flip_max",
           "seed_errors", "evaluated_pp", "evaluated_lit_pp", "shadow_pp", "shadow_bound",
           "exact_pp", "mismatch_count", "capped_lights", "cpu_total_ms", "gpu_lighting_ms",
           "frame_cost_ms", "frame_cost_min_ms", "frame_cost_max_ms", "timing_samples",
           "model_gpus", "model_lighting_ms", "model_frame_ms", "bins"]


@dataclass(frozen=True)
class SamplingConfig:
    """The study's settings: frame 0 of each scene (scenes () none) at `lights` (the stress
    scene at `stress_lights`), every sampler at each of `samples` over
    `seeds` seeds, each culling configuration `repeat` timing samples."""
    scenes: tuple[str, ...]
    lights: int
    size: tuple[int, int]
    samples: tuple[int, ...]
    seeds: int
    repeat: int
    flip: bool = True              # the FLIP columns (one evaluation a seed)
    model: bool = True             # the modelled columns where a frame has a wave replay
    seed: int = 0                  # the scenes' seed
    stress_lights: int = 100_000
    # a culling configuration evaluating more lights a pixel takes fewer timing samples (as
    # the rendered study's heavy_eval_pp / heavy_repeat: brute on the stress scene)
    heavy_eval_pp: float = 4096.0
    heavy_repeat: int = 2
    # lane iterations a width the wave replay walks, as the rendered study's replay_budget
    # (a preset gives both the same: tests)
    replay_budget: int = REPLAY_BUDGET
    replay_segments: int = 0       # the replay's limit on a program's segments (0: none; as
                                   # app.bench.rendered's: predict.frame_figures)


def configurations(samples, dropped: dict[str, int]) -> list[dict]:
    """Every configuration of a frame, brute first (the others' errors need its frame);
    `dropped`: {cap policy: visible lights it drops}."""
    from cpu_prep import caps
    from ..techniques import REGISTRY
    from .caps import cap_techniques
    from .plan import technique_order
    out = [dict(config=n, kind="exact", technique=n, opts=REGISTRY[n].Options(),
                policy=caps.NONE, s=0) for n in technique_order()
           if REGISTRY[n].role != "sampler"]
    for p in caps.NAMES:
        techs = cap_techniques(p)
        if p != caps.NONE and techs and (dropped.get(p) or caps.per_tile(p)):
            t = REGISTRY[techs[0]]
            out.append(dict(config=f"{p} ({t.name})", kind="cap", technique=t.name,
                            opts=t.Options.make({"cap_policy": p}), policy=p, s=0))
    for t in (t for t in REGISTRY.values() if t.role == "sampler"):
        out += [dict(config=f"{t.name} S={s}", kind="sampler", technique=t.name,
                     opts=t.Options.make({"light_samples": int(s)}), policy=caps.NONE, s=int(s))
                for s in samples]
    return out


def bin_index(counts: np.ndarray) -> np.ndarray:
    """Each count's bin k, counts in [2^k, 2^(k+1)) (counts >= 1)."""
    return np.floor(np.log2(np.maximum(counts, 1))).astype(np.int64)


def count_bins(counts: np.ndarray) -> list[tuple[int, int]]:
    """[lo, hi] of each bin [2^k, 2^(k+1)) up to the largest count (counts >= 1)."""
    top = int(counts.max()) if counts.size else 0
    return [(1 << k, (1 << (k + 1)) - 1) for k in range(max(top, 1).bit_length())]


def bin_errors(image, ref_image, lit_counts: np.ndarray, bins, scale: float) -> list[float]:
    """RMSE of radiance over each bin's pixels (lit_counts: brute's contrib_count of the
    geometry pixels, flattened as the images' rows), over `scale`: brute's frame mean."""
    d2 = ((image.astype(np.float64) - ref_image.astype(np.float64)) ** 2).mean(-1)
    k = bin_index(lit_counts)
    n = np.bincount(k, minlength=len(bins))
    sums = np.bincount(k, weights=d2, minlength=len(bins))
    ok = (n > 0) & (scale > 0)
    return [float(v) for v in np.where(ok, np.sqrt(sums / np.maximum(n, 1)) / (scale or 1.0), 0.0)]


class Frame:
    """Brute's frame of a scene and what every configuration's error reads of it."""
    def __init__(self, ref):
        self.ref = ref
        self.mask = ref.depth > 0
        self.counts = ref.contrib_count[self.mask].astype(np.int64)
        self.lit = self.counts > 0
        self.bins = count_bins(self.counts[self.lit])
        img = ref.image[self.mask].astype(np.float64)
        self.scale = float(img.mean()) if img.size else 0.0
        self.pixels = np.bincount(bin_index(self.counts[self.lit]),
                                  minlength=len(self.bins)).tolist()

    def figures(self, res, flip: bool) -> dict:
        """One render's error figures and per-pixel counts against brute."""
        ev = res.evaluated[self.mask].astype(np.float64)
        n = max(int(self.mask.sum()), 1)
        return {"error": measure.image_error(res, self.ref),
                "flip": measure.image_flip(res, self.ref) if flip else float("nan"),
                "bins": bin_errors(res.image[self.mask][self.lit], self.ref.image[self.mask][self.lit],
                                   self.counts[self.lit], self.bins, self.scale),
                "evaluated_pp": float(ev.sum() / n),
                "evaluated_lit_pp": float(ev[self.lit].mean()) if self.lit.any() else 0.0,
                "lit_evaluations_pp": float(ev[self.lit].sum() / n),
                "exact_pp": float(res.contrib_count[self.mask].astype(np.float64).sum() / n)}


def run_frame(renderer, frame_lights, configs, c: SamplingConfig, log=None,
              where: str = "") -> list[dict]:
    """The configurations' rows on one frame (frame 0, `frame_lights`): a warm-up render of
    each technique, then interleaved rounds (module docstring)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..techniques import REGISTRY
    t0 = time.perf_counter()

    def render(cfg, k, readback, figures=None):
        opts = cfg["opts"].with_(sample_seed=k) if cfg["kind"] == "sampler" else cfg["opts"]
        return renderer.render(REGISTRY[cfg["technique"]], 0, opts, frames=64,
                               lights=frame_lights, readback=readback, figures=figures)

    for cfg in {cfg["technique"]: cfg for cfg in configs}.values():     # compilation: not timed
        render(cfg, 0, False)
    state = {cfg["config"]: dict(draws=[], samples=[], meta=None, model=None) for cfg in configs}
    frame = None
    for k in range(max(c.repeat, c.seeds)):
        for cfg in configs:
            st = state[cfg["config"]]
            wants = c.seeds if cfg["kind"] == "sampler" else st.get("wants", c.repeat)
            if k >= wants:
                continue
            first = k == 0
            readback = first or cfg["kind"] == "sampler"
            res = render(cfg, k, readback, figures=first if readback else None)
            st["samples"] += measure.samples_of(res.meta)
            if not readback:
                continue
            frame = frame or Frame(res)          # brute: the first configuration
            st["draws"].append(frame.figures(res, c.flip))
            if first:
                _first(st, renderer, cfg, res, frame, c)
        log.write(f"[sampling {where} round {k + 1}/{max(c.repeat, c.seeds)} "
                  f"{time.perf_counter() - t0:6.1f}s]\n")
        log.flush()
    return [_row(cfg, state[cfg["config"]], frame, renderer.size) for cfg in configs]


def _first(st: dict, renderer, cfg, res, frame: Frame, c: SamplingConfig) -> None:
    """What a configuration's first render alone gives: its light counts, its sets against
    brute's (a sampler's support: figures on), its model, and fewer samples if heavy."""
    stats = res.meta["stats"]
    st["meta"] = (int(stats.get("visible_lights", 0)), int(stats.get("capped_lights", 0)),
                  int((res.contrib_count != frame.ref.contrib_count).sum() +
                      (res.contrib_hash != frame.ref.contrib_hash).sum()),
                  st["draws"][0]["exact_pp"])
    st["model"] = _model(renderer, cfg, res, c.replay_budget, c.replay_segments) if c.model else None
    if st["draws"][0]["evaluated_pp"] > c.heavy_eval_pp:
        st["wants"] = min(c.repeat, c.heavy_repeat)


def _model(renderer, cfg, res, budget: int, segments: int = 0) -> tuple[dict, float] | None:
    """({gpu key: modelled lighting ms}, the replay's affecting draws a geometry pixel) of the
    frame the renderer holds, None without a replay."""
    from ..model import predict
    from ..techniques import REGISTRY
    work = int(res.evaluated.sum(dtype=np.int64)) + int(res.nodes.sum(dtype=np.int64))
    try:
        figures, means = predict.modelled_frame(renderer, REGISTRY[cfg["technique"]], res,
                                                cfg["opts"], sample=max(1, -(-work // budget)),
                                                segments=segments)
    except (NotImplementedError, KeyError, ValueError):   # a technique the replay lacks
        return None
    cells = measure.model_cells(figures)
    return ({k[len("model_"):-len("_lighting_ms")]: v for k, v in cells.items()
             if k.startswith("model_") and k.endswith("_lighting_ms")}, means["exact_pp"])


def _spread(values) -> tuple[float, float, float]:
    a = np.asarray(values, np.float64)
    return float(np.median(a)), float(a.min()), float(a.max())


def _row(cfg, st, frame: Frame, size) -> dict:
    from ..techniques import REGISTRY
    draws = st["draws"]
    visible, capped, mismatch, exact_pp = st["meta"]
    err, flip = _spread([d["error"] for d in draws]), _spread([d["flip"] for d in draws])
    t = measure.timing_cells(st["samples"])
    sampler = cfg["kind"] == "sampler"
    mean = lambda key: float(np.mean([d[key] for d in draws]))
    row = {"study": "sampling", "width": size[0], "height": size[1], "frame": 0,
           "config": cfg["config"], "kind": cfg["kind"], "technique": cfg["technique"],
           "role": REGISTRY[cfg["technique"]].role, "policy": cfg["policy"],
           "samples_per_pixel": cfg["s"] if sampler else "", "seeds": len(draws),
           "image_error": err[0], "image_error_min": err[1], "image_error_max": err[2],
           "image_flip": flip[0], "image_flip_min": flip[1], "image_flip_max": flip[2],
           "seed_errors": json.dumps([round(d["error"], 6) for d in draws]),
           "evaluated_pp": mean("evaluated_pp"), "evaluated_lit_pp": mean("evaluated_lit_pp"),
           "shadow_pp": exact_pp, "shadow_bound": 0, "exact_pp": exact_pp,
           "visible": visible, "capped_lights": capped, "mismatch_count": mismatch,
           "cpu_total_ms": t["cpu_total_ms"], "gpu_lighting_ms": t["gpu_lighting_ms"],
           "frame_cost_ms": t["frame_cost_ms"], "frame_cost_min_ms": t["frame_cost_min_ms"],
           "frame_cost_max_ms": t["frame_cost_max_ms"], "timing_samples": t["samples"],
           "bins": json.dumps({"lo": [b[0] for b in frame.bins], "hi": [b[1] for b in frame.bins],
                               "pixels": frame.pixels, "geometry": int(frame.mask.sum()),
                               "err": [[round(e, 7) for e in d["bins"]] for d in draws]})}
    model, hits = st["model"] or (None, None)
    if sampler:     # its affecting draws (the replay's), else the bound: its lit evaluations
        bound = hits is None
        row.update(shadow_pp=mean("lit_evaluations_pp") if bound else hits, shadow_bound=int(bound))
    if model:       # the first modelled GPU's figures (model_gpus names them all, in order)
        row["model_gpus"] = json.dumps(model)
        key = next(iter(model))
        row["model_lighting_ms"] = model[key]
        row["model_frame_ms"] = t["cpu_total_ms"] + model[key]
    return row


def sampling_series(c: SamplingConfig, out: Path, log=None) -> list[dict]:
    """The study of `c` into out/sampling.csv; none without scenes, samplers or seeds (a stale
    file is removed, so no report shows it)."""
    log = log or sys.stderr      # the stream at the call, not at import (pytest swaps it)
    from ..pipeline.renderer import Renderer
    from ..techniques import REGISTRY
    from .caps import dropped_lights
    files = series_files(out, (CSV,), bool(c.scenes) and bool(c.samples) and c.seeds >= 2 and
                         any(t.role == "sampler" for t in REGISTRY.values()))
    if files is None:
        return []
    path, = files
    rows: list[dict] = []
    for name in c.scenes:
        scene = study_scene(name, c.stress_lights if name == "stress" else c.lights, c.seed)
        lights = scene.lights_at(0, 64)
        configs = configurations(c.samples, dropped_lights(scene, c.size, 0, 64))
        with Renderer(scene, tuple(c.size)) as r:
            got = run_frame(r, lights, configs, c, log, name)
        for row in got:
            row.update(scene=name, lights=len(scene.lights))
        rows += got
    write_series(rows, path, COLUMNS, log)
    return rows


class SamplingStudy(FileStudy):
    """out/sampling.csv (the report's sampling section reads it), none of results.csv's rows."""
    name = "sampling"
    files = (CSV,)
    sections = ("sampling",)
    Config = SamplingConfig
    series = staticmethod(sampling_series)


__all__ = ["SamplingConfig", "SamplingStudy", "sampling_series", "run_frame", "configurations",
           "count_bins", "bin_index", "bin_errors", "COLUMNS", "CSV"]
