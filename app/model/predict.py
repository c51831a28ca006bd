"""Modelled GPU milliseconds of a rendered frame: its passes' wave figures (the culling
passes' from its replay.py's cull_figures, the shading pass's replayed from its
wave_program) at each named GPU's wave width, through the cost model.

    frame_figures(renderer, technique, result)  -> {width: {pass: Figures}}
    modelled(figures)                           -> {gpu key: {"cull", "shade", "bound"}}
"""
from __future__ import annotations

import numpy as np

from ..pipeline import phases
from ..techniques import parts
from . import cost, counts, waves

SHADE = "shade"        # the shading pass's name in the figures (its timed passes may be many)


def frame_figures(renderer, technique, result, opts=None, unbounded: bool = False,
                  widths=waves.WIDTHS, sample: int = 1, budget: int | None = None,
                  segments: int = 0) -> dict[int, dict[str, waves.Figures]]:
    """Every timed pass's figures at each wave width, for the frame the renderer just
    rendered with read-back (its buffers are still there).  `sample` > 1 replays the
    shading pass over every sample-th 8x8 group only and scales (waves.sampled); `budget`
    chooses that sample from the frame's own counters: about `budget` lane iterations (the
    lights and nodes its pixels visited) a width.  `segments` (0: no limit): a shading
    program of more segments than that (a sampler's CDF searches are segments the counters
    do not show) is replayed over a sample that many times sparser again, for every width."""
    if budget and getattr(result, "evaluated", None) is not None:
        work = int(result.evaluated.sum(dtype=np.int64))
        if getattr(result, "nodes", None) is not None:
            work += int(result.nodes.sum(dtype=np.int64))
        sample = max(sample, -(-work // budget))
    return _figures(renderer, technique, result, opts, unbounded, widths, sample, segments)[0]


def modelled_or_none(renderer, technique, result, opts=None, **kw):
    """frame_figures(), or None for a technique that gives no wave program (Technique's
    default: a throw-away technique of the tests, say): its rows have no modelled columns."""
    try:
        return frame_figures(renderer, technique, result, opts, **kw)
    except NotImplementedError:
        return None


def modelled_frame(renderer, technique, result, opts=None, sample: int = 1, segments: int = 0):
    """(figures, per-pixel means the 64-lane replay implies over the shading pixels it
    replayed: evaluated_pp, exact_pp, nodes_pp, waste) of a frame rendered with the shading
    passes' CELLS_ONLY switch (their light loops skipped: the replay stands for them);
    `segments` as frame_figures'."""
    figures, rp, shading = _figures(renderer, technique, result, opts, False, waves.WIDTHS, sample,
                                    segments)
    ev, ex, nd = (a[shading].astype(np.float64) for a in (rp.evaluated, rp.contrib, rp.nodes))
    mean = lambda a: float(a.mean()) if len(a) else 0.0
    return figures, {"evaluated_pp": mean(ev), "exact_pp": mean(ex), "nodes_pp": mean(nd),
                     "waste": float(ev.sum() / ex.sum()) if ex.sum() else float("nan")}


@phases.timed("replay")           # app.pipeline.phases: where a run's time goes
def _figures(renderer, technique, result, opts, unbounded, widths, sample, segments=0):
    opts = technique.resolve_options(opts)
    fr = waves.frame_data(renderer, result, opts, unbounded)
    part, share = waves.sampled(fr, sample)
    built = []                      # (width, its culling passes, its program, its replay)
    for k, width in enumerate(widths):
        passes = dict(parts.cull_figures(technique, fr, width))
        prog = parts.wave_program(technique, part, width)
        if segments and not built and prog.segment_count() > segments:   # the first width decides
            sample *= -(-prog.segment_count() // segments)
            part, share = waves.sampled(fr, sample)
            prog = parts.wave_program(technique, part, width)
        # every width but the last replays on the worker thread (its kernels release the
        # GIL) while this one builds the next width's program (reading the frame's buffers:
        # the GL context is this thread's) and replays the last; each replay reads its own
        # program alone, so the figures are the same as one after the other
        run = _replayer().submit(waves.replay, prog) if k < len(widths) - 1 else waves.replay(prog)
        built.append((width, passes, prog, run))
    out, last = {}, None
    for width, passes, prog, run in built:
        last = run if isinstance(run, waves.Replay) else run.result()
        shade = last.figures
        passes[SHADE] = shade if share >= 1.0 else shade.scaled(1.0 / max(share, 1e-9), prog.buffers)
        counts.attach(passes, fr.programs)
        out[width] = passes
    return out, last, part.shading


_REPLAYER: list = []     # the worker thread of _figures' replays (made on first use)


def _replayer():
    if not _REPLAYER:
        from concurrent.futures import ThreadPoolExecutor
        _REPLAYER.append(ThreadPoolExecutor(max_workers=1, thread_name_prefix="replay"))
    return _REPLAYER[0]


def from_json(text: str) -> dict[int, dict[str, waves.Figures]]:
    """The figures a results row's `waves` column holds (app.bench.measure.model_cells)."""
    import json
    return {int(w): {name: waves.Figures.from_dict(d) for name, d in passes.items()}
            for w, passes in json.loads(text).items()}


def modelled(figures: dict[int, dict[str, waves.Figures]], gpus=cost.GPUS) -> dict[str, dict]:
    """Per GPU: culling and shading ms, and which limit bounds the shading pass."""
    out = {}
    for g in gpus:
        passes = figures[g.wave]
        cull = sum(cost.pass_ms(f, g) for name, f in passes.items() if name != SHADE)
        out[g.key] = {"cull": cull, "shade": cost.pass_ms(passes[SHADE], g),
                      "bound": cost.bound(passes[SHADE], g)}
    return out
