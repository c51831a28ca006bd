"""zbin: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from cpu_prep import zbin as zb

from ...model import waves
from ..bit_arrays import add_bit_words, variant_flags
from .. import variants
from . import DEPTH_GROUP, _shaded_bits


def wave_program(technique, frame, width):
    opts = frame.opts
    masked, scalarized = variant_flags(opts.zbin_variant)
    prog = waves.Program(frame, width)
    add_bit_words(prog, _shaded_bits(opts), frame.build.grid,
                  masked, scalarized, opts.printed_mask)
    return prog


def cull_figures(technique, frame, width):
    """zbin_tile_depth.comp: per tile one 8x8 group, its pixels' depths, then each lane's
    words and, per set bit, the light's depth range."""
    if not frame.opts.tile_depth:
        return variants.figures_if_on(frame, width, technique._bit_scans, {})
    g, n = frame.build.grid, len(frame.build.lights)
    words = zb.words_for(n)
    pixels, covered, *_ = waves.per_tile(frame, g.tile)
    tiles = g.tiles_x * g.tiles_y
    per = DEPTH_GROUP // width
    texels = (-(-g.tile // 8)) ** 2
    bits = np.ascontiguousarray(frame.build.buffers["tile_bits"]).view(np.uint8)
    set_bits = int(np.unpackbits(bits).sum())
    rounds = -(-words // DEPTH_GROUP)
    line = lambda issued, nbytes: issued * width * nbytes // waves.LINE
    depth = (tiles * per * texels, int(pixels.sum()), tiles * per * texels,
             line(tiles * per * texels, 16))
    test = (tiles * per * rounds + -(-set_bits // width), set_bits + tiles * words,
            tiles * per * rounds + -(-set_bits // width), line(tiles * per * rounds, 4))
    return variants.figures_if_on(frame, width, technique._bit_scans, {"zbin tile depth": waves.analytic(
        width, tiles * per, {"depth": depth, "cull_test": test},
        {"g_position": int(pixels.sum()) * 16, "tile_bits": tiles * words * 4,
         "light_depth": n * 8, "zbin_bits": tiles * words * 4},
        barriers=2 * tiles, shared_atomics=2 * int(covered.sum()))})
