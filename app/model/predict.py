"""Modelled GPU milliseconds of a rendered frame: its passes' wave figures (the culling
passes' from Technique.cull_figures, the shading pass's replayed from its wave_program) at
each named GPU's wave width, through the cost model.

    frame_figures(renderer, technique, result)  -> {width: {pass: Figures}}
    modelled(figures)                           -> {gpu key: {"cull", "shade", "bound"}}
"""
from __future__ import annotations

from . import cost, waves

SHADE = "shade"        # the shading pass's name in the figures (its timed passes may be many)


def frame_figures(renderer, technique, result, opts=None, unbounded: bool = False,
                  widths=waves.WIDTHS) -> dict[int, dict[str, waves.Figures]]:
    """Every timed pass's figures at each wave width, for the frame the renderer just
    rendered with read-back (its buffers are still there)."""
    opts = technique.resolve_options(opts)
    fr = waves.frame_data(renderer, result, opts, unbounded)
    out = {}
    for width in widths:
        passes = dict(technique.cull_figures(fr, width))
        passes[SHADE] = waves.replay(technique.wave_program(fr, width)).figures
        out[width] = passes
    return out


def modelled(figures: dict[int, dict[str, waves.Figures]], gpus=cost.GPUS) -> dict[str, dict]:
    """Per GPU: culling and shading ms, and which limit bounds the shading pass."""
    out = {}
    for g in gpus:
        passes = figures[g.wave]
        cull = sum(cost.pass_ms(f, g) for name, f in passes.items() if name != SHADE)
        out[g.key] = {"cull": cull, "shade": cost.pass_ms(passes[SHADE], g),
                      "bound": cost.bound(passes[SHADE], g)}
    return out
