"""fptl: what the GPU cost model needs (app.model): the shading pass as the wave replay's
segments (wave_program) and the figures of the passes before it (cull_figures)."""
from __future__ import annotations

import numpy as np

from ...model import waves
from .. import variants
from ..replay_walks import add_all_lights
from . import (COARSE_BATCH, FLAG_POOL_FULL, FLAG_SPILLED, FPTL_AABB, FPTL_CELL, LIST_CAP,
               LOOP_ORDER, TILE, _LOOP_RANK, decode_lists, decode_state, index_bits, list_words,
               state_bytes, variant_flags)


def cull_figures(technique, frame, width):
    """fptl_aabb.comp (a light a lane) and fptl_lists.comp (per 16x16 tile one 64-lane
    group: the 2x2 pixels' depths, the coarse AABB test 64 lights a round, then fine
    pruning: every lane tests its four pixels against each coarse light); with
    --feature-variants its shape words (a shared atomic per kept entry, the word written
    each scan window) and the classification passes (variants.cull_figures)."""
    b = frame.build
    g, n = b.grid, len(b.lights)
    fine, _ = variant_flags(frame.opts.fptl_variant)
    per = 64 // width
    light_waves = max(1, -(-n // 64)) * per
    line = lambda issued, nbytes: issued * width * nbytes // waves.LINE
    aabb = waves.analytic(width, light_waves,
                          {"aabb": (light_waves, n, 3 * light_waves, line(light_waves, 116))},
                          {"lights": n * 96, "bounds": n * 16, "fptl_order": n * 4,
                           "fptl_aabbs": n * FPTL_AABB.itemsize})
    tiles = g.tiles_x * g.tiles_y
    cells = frame.read("fptl_cells").view(FPTL_CELL).reshape(tiles, g.slices)
    coarse = cells["coarse"][:, 0].astype(np.int64)
    pixels, covered, *_ = waves.per_tile(frame, TILE)
    busy = int((covered > 0).sum())
    rounds = -(-n // COARSE_BATCH) + 1
    flushes = int((-(-coarse // COARSE_BATCH)).sum())
    depth = (tiles * per * 4, pixels.sum(), tiles * per * 4, line(tiles * per * 4, 16))
    test = (busy * per * rounds, busy * n, busy * per * rounds, line(busy * per * rounds, 32))
    prune_it = per * int(coarse.sum() if fine else flushes)
    prune = (prune_it, prune_it * width, 0, 0, prune_it, 2 * prune_it)
    words = list_words(index_bits(n))
    shapes = variants.on(b, frame.opts)
    lists = waves.analytic(
        width, tiles * per, {"depth": depth, "cull_test": test, "prune": prune},
        {"g_position": int(pixels.sum()) * 16, "fptl_aabbs": n * FPTL_AABB.itemsize,
         "lights": min(int(coarse.sum()), n) * 96, "fptl_lists": g.cells * words * 4,
         "fptl_cells": g.cells * FPTL_CELL.itemsize,
         **({"cell_features": g.cells * 4 * len(b.own.scans)} if shapes else {})},
        barriers=tiles * (6 + 3 * rounds) + 4 * flushes,
        shared_atomics=4 * int(covered.sum()) + int(coarse.sum()) + 8 * 64 * flushes
        + (int(cells["pruned"].sum()) if shapes else 0),
        atomics=int((cells["flags"] & FLAG_SPILLED != 0).sum()))
    return variants.figures_if_on(frame, width, None, {"light_aabb": aabb, "fptl_lists": lists})


def wave_program(technique, frame, width):
    """fptl_shade.comp: the cell's list words (the eight blocks, or the wide formats'
    count word), whose in-band state says the length and whether the cell spilled or
    shades every light; then its packed list, and each scan window's spill head and
    spill for spilled cells only; every run as one loop per shape compiled (type_loops)
    or one loop."""
    prog = waves.Program(frame, width)
    b, opts = frame.build, frame.opts
    bits = index_bits(len(b.lights))
    lanes = np.nonzero(frame.shading)[0]
    words = frame.read("fptl_lists")
    listed, state = decode_state(words, bits)
    cell = frame.cell[lanes]
    prog.add(lanes, head=("cell", "fptl_lists", cell * list_words(bits) * 4,
                          state_bytes(bits), False))
    full = (state[cell] & FLAG_POOL_FULL) != 0
    add_all_lights(prog, lanes[full], step=1, branch=1)
    lanes, cell = lanes[~full], cell[~full]
    shapes = np.unique(b.lights.type)            # the shapes whose loops are compiled
    idx, off = decode_lists(words, bits)
    main = prog.add_list(idx.ravel(), entry_off=off.ravel(), entry_buf="fptl_lists")
    _add_runs(prog, lanes, main, cell * LIST_CAP, listed[cell], 8, shapes, opts.type_loops)
    heads = np.ascontiguousarray(frame.read("fptl_spill_heads")).view(np.uint32).reshape(-1, 2).astype(np.int64)
    spilled = (state[cell] & FLAG_SPILLED) != 0
    if spilled.any():
        lanes, cell = lanes[spilled], cell[spilled]
        used = int(heads.sum(1).max(initial=0))
        spill = prog.add_list(frame.read("fptl_spill")[:used], entry_off=4 * np.arange(used),
                              entry_buf="fptl_spill")
        for scan in range(len(b.own.scans)):
            h = scan * b.grid.cells + cell
            step = 8 * (2 + scan)
            prog.add(lanes, step=step, head=("cell", "fptl_spill_heads", h * 8, 8, False))
            _add_runs(prog, lanes, spill, heads[h, 0], heads[h, 1], step + 1, shapes,
                      opts.type_loops)
    return prog


def _add_runs(prog, lanes, list_id: int, first, count, step: int, shapes, type_loops: bool) -> None:
    """One run of a list per lane (fptl_shade.comp shade_run): its entries, in shape order,
    as one loop per shape compiled (each its own step), or one loop."""
    first, count = np.asarray(first, np.int64), np.asarray(count, np.int64)
    if not type_loops:
        prog.add(lanes, step=step, lights=(list_id, first, count, False))
        return
    L = prog.lists[list_id]
    rank = _LOOP_RANK[prog.frame.build.lights.type[L.light].astype(np.intp)] if len(L.light) \
        else np.zeros(0, np.uint8)
    start = first.copy()
    for t in LOOP_ORDER:
        if t not in shapes:
            continue
        cum = np.concatenate([[0], np.cumsum(rank == _LOOP_RANK[t])])
        n = cum[first + count] - cum[first]
        prog.add(lanes, step=step + int(_LOOP_RANK[t]), lights=(list_id, start, n, False))
        start = start + n
